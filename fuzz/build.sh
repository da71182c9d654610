#!/bin/bash -eu
# OSS-Fuzz / ClusterFuzzLite build script for visgate (DESIGN section 9; ../shared/STYLE.md
# "Fuzzing"). Runs inside the OSS-Fuzz base-builder image (see .clusterfuzzlite/), which
# sets $CC, $CXX, $CFLAGS, $CXXFLAGS (sanitizer and coverage flags), $LIB_FUZZING_ENGINE,
# $SRC, $WORK and $OUT. Builds every fuzz target through fuzz/CMakeLists.txt
# (VISGATE_BUILD_FUZZERS=ON, VISGATE_FUZZING_ENGINE=$LIB_FUZZING_ENGINE) and copies to
# $OUT: each binary, its seed corpus as <target>_seed_corpus.zip, its <target>.options
# and the dictionaries the options name.
#
# Local use without docker (clang-14 on Debian 12):
#   CC=clang-14 CXX=clang++-14 CFLAGS="-fsanitize=address,fuzzer-no-link" \
#   CXXFLAGS="-fsanitize=address,fuzzer-no-link" LIB_FUZZING_ENGINE=-fsanitize=fuzzer \
#   SRC=$PWD/.. WORK=/tmp/vg-work OUT=/tmp/vg-out fuzz/build.sh

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="$WORK/visgate-build"

# The prebuilt system libraries (OpenMesh, Embree, TBB) use libstdc++; OSS-Fuzz's
# default -stdlib=libc++ would break their ABI. libFuzzer carries its own private libc++.
CXXFLAGS="${CXXFLAGS//-stdlib=libc++/}"
# UBSan's vptr check stops every region-oracle run inside CGAL's arrangement iterators
# (a third-party downcast, see fuzz/configure-clang.sh); it stays off.
CFLAGS="$CFLAGS -fno-sanitize=vptr"
CXXFLAGS="$CXXFLAGS -fno-sanitize=vptr"
# No coverage feedback from the oracles and third-party headers (fuzz/coverage-ignorelist.txt),
# where coverage instrumentation is on at all (not in OSS-Fuzz's coverage builds).
case "$CXXFLAGS" in
  *fuzzer-no-link*|*sanitize-coverage*)
    CFLAGS="$CFLAGS -fsanitize-coverage-ignorelist=$ROOT/fuzz/coverage-ignorelist.txt"
    CXXFLAGS="$CXXFLAGS -fsanitize-coverage-ignorelist=$ROOT/fuzz/coverage-ignorelist.txt" ;;
esac

cmake -S "$ROOT" -B "$BUILD" \
  -DCMAKE_BUILD_TYPE=Release \
  -DCMAKE_C_COMPILER="$CC" -DCMAKE_CXX_COMPILER="$CXX" \
  -DCMAKE_C_FLAGS="$CFLAGS" -DCMAKE_CXX_FLAGS="$CXXFLAGS" \
  -DCMAKE_C_FLAGS_RELEASE="-DNDEBUG" -DCMAKE_CXX_FLAGS_RELEASE="-DNDEBUG" \
  -DVISGATE_BUILD_FUZZERS=ON -DVISGATE_FUZZING_ENGINE="$LIB_FUZZING_ENGINE" \
  -DVISGATE_BUILD_TESTS=OFF -DVISGATE_CGAL_NO_THREADS=ON
cmake --build "$BUILD" -j"$(nproc)" --target visgate_fuzzers

for bin in "$BUILD"/fuzz/fuzz_*; do
  [ -x "$bin" ] && [ -f "$bin" ] || continue
  t="$(basename "$bin")"
  # fuzz_plugin fuzzes a plugin named by VISGATE_FUZZ_PLUGIN; without one it does nothing.
  [ "$t" = fuzz_plugin ] && continue
  cp "$bin" "$OUT/"
  if [ -d "$ROOT/corpus/fuzz/$t" ]; then
    (cd "$ROOT/corpus/fuzz/$t" && zip -q -j -r "$OUT/${t}_seed_corpus.zip" .)
  fi
  if [ -f "$ROOT/fuzz/$t.options" ]; then
    cp "$ROOT/fuzz/$t.options" "$OUT/"
  fi
done
cp "$ROOT"/fuzz/*.dict "$OUT/"
