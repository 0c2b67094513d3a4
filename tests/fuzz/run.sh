#!/bin/sh
# Builds each libFuzzer harness in tests/fuzz with clang++ -fsanitize=fuzzer,address,undefined
# (with only the codec sources it needs) and runs it for FUZZ_SECONDS (default 6) seconds.
# Usage: run.sh CLANGXX SOURCE_DIR WORK_DIR [DATA_ROOT]   (DATA_ROOT/data/traces holds the Vive capture seed)
# Exit 77 (CTest: skipped) when clang++ cannot link libFuzzer; says so on stderr.
set -eu
CXX="$1"; SRC="$2"; WORK="$3"; SHARED="${4:-$SRC}"
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
build vive_imu_fuzz "$SRC/hal/src/codec/vive_imu_codec.cpp"
build rift_imu_fuzz "$SRC/hal/src/codec/rift_imu_codec.cpp"
build reference_protocol_fuzz "$SRC/hal/src/codec/reference_protocol.cpp"
build usbmon_capture_fuzz "$SRC/hal/src/transport/usbmon_capture.cpp" -lpcap -lz
# The .hmpm reader needs the collapse engine and its costs (refine); the harness stubs the two
# symbols of simplify.cpp. The mesh-file reader needs core's OBJ reader; the harness stubs glTF.
build progressive_mesh_fuzz -I"$SRC/lod/include" -I"$SRC/lod/src" \
  "$SRC/lod/src/progressive_mesh.cpp" "$SRC/lod/src/collapse_engine.cpp" "$SRC/lod/src/qem.cpp" \
  "$SRC/lod/src/curvature_qem.cpp" "$SRC/lod/src/formula1.cpp" "$SRC/lod/src/melax.cpp" \
  "$SRC/lod/src/scratch.cpp" \
  "$SRC/core/src/atomic_file.cpp"
build mesh_file_fuzz -I"$SRC/lod/include" "$SRC/lod/src/mesh_file.cpp" "$SRC/core/src/obj.cpp" \
  "$SRC/core/src/atomic_file.cpp" "$SRC/core/src/scene.cpp"

# Seeds: a valid prefix of the real capture (plain and gzip'd) (data/traces).
mkdir -p "$WORK/corpus/usbmon_capture_fuzz" "$WORK/corpus/vive_imu_fuzz" \
  "$WORK/corpus/reference_protocol_fuzz" "$WORK/corpus/rift_imu_fuzz" \
  "$WORK/corpus/progressive_mesh_fuzz" "$WORK/corpus/mesh_file_fuzz"
if [ -f "$SHARED/data/traces/vive_cal.pcap.gz" ]; then
  gzip -dc "$SHARED/data/traces/vive_cal.pcap.gz" 2>/dev/null | head -c 6000 \
    > "$WORK/corpus/usbmon_capture_fuzz/seed.pcap" || true
  gzip -c "$WORK/corpus/usbmon_capture_fuzz/seed.pcap" > "$WORK/corpus/usbmon_capture_fuzz/seed.pcap.gz"
fi

# A small valid .hmpm (normals; a triangle and one vertex split) and one file per mesh format
# (first byte: 1 = named .obj, 0 = .ply).
le32() { for v in "$@"; do printf "$(printf '\\%03o\\%03o\\%03o\\%03o' $((v & 255)) \
  $((v >> 8 & 255)) $((v >> 16 & 255)) $((v >> 24 & 255)))"; done; }
ONE=1065353216  # 1.0f
{ printf 'HMPM'; le32 1 1 4294967295 4 4 2 3 3 1 1 \
    0 0 0 0  1 $ONE 0 0  2 0 $ONE 0 \
    0 0 0 0 $ONE  1 1 0 0 $ONE  2 2 0 0 $ONE \
    0 0 1 2 \
    3 0 0 $ONE  0 0 0 0  1 1 1 1  3 0 0 $ONE  0 0 0 $ONE  1 1 2 3  0 3
} > "$WORK/corpus/progressive_mesh_fuzz/seed.hmpm"
printf '1v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3/1/1\n' \
  > "$WORK/corpus/mesh_file_fuzz/seed.obj"
printf '0ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty float u\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1 0\n1 0 0 2 1\n0 1 0 3 1\n3 0 1 2\n' \
  > "$WORK/corpus/mesh_file_fuzz/seed.ply"
{ printf '0ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n'
  printf '\000\000\000\000\000\000\000\000\000\000\000\000\077\200\000\000\000\000\000\000\000\000\000\000\000\000\000\000\077\200\000\000\000\000\000\000'
  printf '\003\000\000\000\000\000\000\000\001\000\000\000\002'
} > "$WORK/corpus/mesh_file_fuzz/seed_be.ply"
printf '0OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n' > "$WORK/corpus/mesh_file_fuzz/seed.off"

status=0
for f in vive_imu_fuzz rift_imu_fuzz reference_protocol_fuzz usbmon_capture_fuzz \
         progressive_mesh_fuzz mesh_file_fuzz; do
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
