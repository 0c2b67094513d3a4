#!/bin/sh
# Builds each libFuzzer harness in tests/fuzz with clang++ -fsanitize=fuzzer,address,undefined
# (with only the codec sources it needs) and runs it for FUZZ_SECONDS (default 6) seconds.
# Usage: run.sh CLANGXX SOURCE_DIR WORK_DIR [SHARED_DIR]
# Exit 77 (CTest: skipped) when clang++ cannot link libFuzzer; says so on stderr.
set -eu
CXX="$1"; SRC="$2"; WORK="$3"; SHARED="${4:-$SRC/../shared}"
SECONDS_EACH="${FUZZ_SECONDS:-6}"
mkdir -p "$WORK"
FLAGS="-std=c++20 -O1 -g -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=undefined \
  -I$SRC/core/include -I$SRC/hal/include"

printf '#include <cstdint>\n#include <cstddef>\nextern "C" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }\n' \
  > "$WORK/probe.cpp"
if ! "$CXX" $FLAGS "$WORK/probe.cpp" -o "$WORK/probe" 2> "$WORK/probe.log"; then
  echo "fuzz: SKIPPED -- $CXX cannot link libFuzzer (install clang and libfuzzer-14-dev):" >&2
  cat "$WORK/probe.log" >&2
  exit 77
fi

build() {  # name, extra sources..., then -l flags
  name="$1"; shift
  echo "fuzz: building $name" >&2
  "$CXX" $FLAGS "$SRC/tests/fuzz/$name.cpp" "$@" -o "$WORK/$name"
}
build vive_imu_fuzz "$SRC/hal/src/vive_imu_codec.cpp"
build rift_imu_fuzz "$SRC/hal/src/rift_imu_codec.cpp"
build reference_protocol_fuzz "$SRC/hal/src/reference_protocol.cpp"
build usbmon_capture_fuzz "$SRC/hal/src/usbmon_capture.cpp" -lpcap -lz

# Seeds: a valid prefix of the real capture (plain and gzip'd) when the shared data is there.
mkdir -p "$WORK/corpus/usbmon_capture_fuzz" "$WORK/corpus/vive_imu_fuzz" \
  "$WORK/corpus/reference_protocol_fuzz" "$WORK/corpus/rift_imu_fuzz"
if [ -f "$SHARED/data/traces/vive_cal.pcap.gz" ]; then
  gzip -dc "$SHARED/data/traces/vive_cal.pcap.gz" 2>/dev/null | head -c 6000 \
    > "$WORK/corpus/usbmon_capture_fuzz/seed.pcap" || true
  gzip -c "$WORK/corpus/usbmon_capture_fuzz/seed.pcap" > "$WORK/corpus/usbmon_capture_fuzz/seed.pcap.gz"
fi

status=0
for f in vive_imu_fuzz rift_imu_fuzz reference_protocol_fuzz usbmon_capture_fuzz; do
  echo "fuzz: running $f for ${SECONDS_EACH} s" >&2
  if ! (cd "$WORK" && "./$f" -max_total_time="$SECONDS_EACH" -max_len=8192 -print_final_stats=1 \
        "corpus/$f" > "$f.log" 2>&1); then
    echo "fuzz: $f FAILED; see $WORK/$f.log (crash input saved there)" >&2
    tail -40 "$WORK/$f.log" >&2
    status=1
  else
    grep -E "stat::number_of_executed_units" "$WORK/$f.log" | sed "s/^/fuzz: $f /" >&2 || true
  fi
done
exit $status
