#!/usr/bin/env bash
# Configures a clang-14 libFuzzer build of visgate (DESIGN section 9) in BUILD_DIR: the
# fuzz targets with -fsanitize=fuzzer,address,undefined (fuzz/CMakeLists.txt), every
# library with -fsanitize=fuzzer-no-link,address,undefined (coverage for libFuzzer),
# -O2 with line tables, no tests (OSS-Fuzz uses -O1; -O2 runs more inputs a second,
# docs/log/fuzzing.md).
# UBSan's vptr check is left out of the libraries: CGAL's arrangement iterators (region
# oracle) downcast to a type the object does not have
# (CGAL/Arrangement_2/Arrangement_2_iterators.h:458), a third-party finding that would
# stop every fuzz_plucker run; the fuzz targets' own code keeps it.
# UBSan's object-size check is left out everywhere: next to ASan it adds nothing (both
# flag an access past the allocated object, ASan also the ones the compiler cannot size),
# and clang-14 inlines no function that carries it, at -O1 or -O2, so every small inline
# helper of the code under test (dot, cross, Vec3 operators) would become a call.
# Single-threaded: CGAL without thread safety (VISGATE_CGAL_NO_THREADS, the root
# CMakeLists.txt): the targets run one input at a time on one thread.
# Used by tools/fuzz-smoke.sh and tools/fuzz-campaign.sh; then build with
#   cmake --build BUILD_DIR -j2 --target visgate_fuzzers
#
# VISGATE_FUZZ_SANITIZE=0 configures the same targets with libFuzzer alone (no ASan or
# UBSan): about three times the runs per second, for hunting mismatches (logic errors
# need no sanitizer; docs/log/fuzzing.md). Crashes it finds are replayed in
# the sanitized build before they are judged.
#
# Usage: [VISGATE_FUZZ_SANITIZE=0] fuzz/configure-clang.sh BUILD_DIR
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:?usage: fuzz/configure-clang.sh BUILD_DIR}"
mkdir -p "$BUILD"
FLAGS="-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize=vptr,object-size -fno-sanitize-recover=undefined"
ENGINE=(-DVISGATE_FUZZING_ENGINE=)  # explicit: a build dir configured without sanitizers keeps it cached
if [ "${VISGATE_FUZZ_SANITIZE:-1}" = 0 ]; then
  FLAGS="-fsanitize=fuzzer-no-link"
  ENGINE=(-DVISGATE_FUZZING_ENGINE=-fsanitize=fuzzer)
fi
FLAGS="$FLAGS -fno-omit-frame-pointer -gline-tables-only"
# No coverage feedback from the oracles and from third-party headers (see the file).
FLAGS="$FLAGS -fsanitize-coverage-ignorelist=$ROOT/fuzz/coverage-ignorelist.txt"
cmake -S "$ROOT" -B "$BUILD" \
  -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
  -DCMAKE_C_FLAGS="$FLAGS" -DCMAKE_CXX_FLAGS="$FLAGS" \
  -DCMAKE_C_FLAGS_RELEASE="-O2 -DNDEBUG" -DCMAKE_CXX_FLAGS_RELEASE="-O2 -DNDEBUG" \
  "${ENGINE[@]}" -DVISGATE_BUILD_FUZZERS=ON -DVISGATE_SANITIZE=OFF -DVISGATE_BUILD_TESTS=OFF \
  -DVISGATE_CGAL_NO_THREADS=ON > "$BUILD/configure.log" 2>&1 || {
  cat "$BUILD/configure.log" >&2
  exit 1
}
