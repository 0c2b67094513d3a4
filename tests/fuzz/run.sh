#!/bin/sh
# Configures and builds the fuzz build of this project (HMDNODE_FUZZ=ON, tests/fuzz/CMakeLists.txt:
# one libFuzzer executable per tests/fuzz/*_fuzz.cpp, linked to the library of the parser sources
# they reach, all compiled by clang++ with the fuzzer's coverage and -fsanitize=address,undefined) in
# WORK_DIR/build, then runs each harness for FUZZ_SECONDS (default 10) seconds on its seeds (as many
# at once as FUZZ_RUN_JOBS, default the cores online): the
# committed ones (tests/fuzz/seeds/<harness>/) and those made below from the data.
# Usage: run.sh CMAKE GENERATOR CLANGXX SOURCE_DIR WORK_DIR   (FUZZ_JOBS: build jobs, default 2)
# Exit 77 (CTest: skipped) when clang++ cannot link libFuzzer; says so on stderr. A harness that
# does not build, or finds a crash, fails the run.
set -eu
CMAKE="$1"; GEN="$2"; CXX="$3"; SRC="$4"; WORK="$5"
SECONDS_EACH="${FUZZ_SECONDS:-10}"
mkdir -p "$WORK"

printf '#include <cstdint>\n#include <cstddef>\nextern "C" int LLVMFuzzerTestOneInput(const uint8_t*, size_t) { return 0; }\n' \
  > "$WORK/probe.cpp"
if ! "$CXX" -fsanitize=fuzzer,address,undefined "$WORK/probe.cpp" -o "$WORK/probe" \
     2> "$WORK/probe.log"; then
  echo "fuzz: SKIPPED -- $CXX cannot link libFuzzer (install clang and libfuzzer-14-dev):" >&2
  cat "$WORK/probe.log" >&2
  exit 77
fi

# note: the C compiler beside clang++ (clang++-14 -> clang-14); the project is C++ but CMake
# checks both, and gcc would not take the fuzz flags.
CC_BESIDE=$(dirname "$CXX")/$(basename "$CXX" | sed 's/clang++/clang/')
echo "fuzz: configuring and building the harnesses in $WORK/build" >&2
if ! { "$CMAKE" -S "$SRC" -B "$WORK/build" -G "$GEN" -DCMAKE_BUILD_TYPE=Debug \
         -DCMAKE_CXX_COMPILER="$CXX" -DCMAKE_C_COMPILER="$CC_BESIDE" -DHMDNODE_FUZZ=ON \
         -DHMDNODE_BUILD_TESTS=OFF -DHMDNODE_BUILD_BENCH=OFF &&
       "$CMAKE" --build "$WORK/build" --target hmdnode_fuzzers -j "${FUZZ_JOBS:-2}"; } \
     > "$WORK/build.log" 2>&1; then
  echo "fuzz: the fuzz build FAILED; see $WORK/build.log" >&2
  tail -60 "$WORK/build.log" >&2
  exit 1
fi
HARNESSES=$(for f in "$SRC"/tests/fuzz/*_fuzz.cpp; do basename "$f" .cpp; done)
for f in $HARNESSES; do
  mkdir -p "$WORK/corpus/$f"
  if [ -d "$SRC/tests/fuzz/seeds/$f" ]; then cp "$SRC/tests/fuzz/seeds/$f"/* "$WORK/corpus/$f/"; fi
done

# Seeds: a valid prefix of the real capture (plain and gzip'd) (data/traces).
if [ -f "$SRC/data/traces/vive_cal.pcap.gz" ]; then
  gzip -dc "$SRC/data/traces/vive_cal.pcap.gz" 2>/dev/null | head -c 6000 \
    > "$WORK/corpus/usbmon_capture_fuzz/seed.pcap" || true
  gzip -c "$WORK/corpus/usbmon_capture_fuzz/seed.pcap" > "$WORK/corpus/usbmon_capture_fuzz/seed.pcap.gz"
fi

# Lines of the real libsurvive recording: IMU samples, poses, an option line, light lines (under
# the 8192 bytes a run reads of an input).
if [ -f "$SRC/data/traces/compare-test-index.rec.gz" ]; then
  { gzip -dc "$SRC/data/traces/compare-test-index.rec.gz" 2>/dev/null | head -n 600 | tail -n 40
    gzip -dc "$SRC/data/traces/compare-test-index.rec.gz" 2>/dev/null | grep -m 25 ' T20 i '
    gzip -dc "$SRC/data/traces/compare-test-index.rec.gz" 2>/dev/null | grep -m 5 ' T20 POSE '
    gzip -dc "$SRC/data/traces/compare-test-index.rec.gz" 2>/dev/null | grep -m 30 ' T20 [WBY] '
    gzip -dc "$SRC/data/traces/compare-test-index.rec.gz" 2>/dev/null | grep -m 2 ' LH_POSE '
  } > "$WORK/corpus/survive_recording_fuzz/seed.rec" || true
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

# One harness per core at a time (FUZZ_RUN_JOBS, default the cores online): each runs its fixed
# time whatever the others do, so the lane takes 10 s times the harnesses over the cores.
run_one() {
  if ! (cd "$WORK" && "build/tests/fuzz/$1" -max_total_time="$SECONDS_EACH" -max_len=8192 -print_final_stats=1 \
        "corpus/$1" > "$1.log" 2>&1); then
    echo "fuzz: $1 FAILED; see $WORK/$1.log (crash input saved there)" >&2
    tail -40 "$WORK/$1.log" >&2
    return 1
  fi
  grep -E "stat::number_of_executed_units" "$WORK/$1.log" | sed "s/^/fuzz: $1 /" >&2 || true
}
JOBS="${FUZZ_RUN_JOBS:-$(getconf _NPROCESSORS_ONLN 2>/dev/null || echo 1)}"
status=0
pids=""
running=0
for f in $HARNESSES; do
  echo "fuzz: running $f for ${SECONDS_EACH} s" >&2
  run_one "$f" &
  pids="$pids $!"
  running=$((running + 1))
  if [ "$running" -ge "$JOBS" ]; then
    for p in $pids; do wait "$p" || status=1; done
    pids=""
    running=0
  fi
done
for p in $pids; do wait "$p" || status=1; done
exit $status
