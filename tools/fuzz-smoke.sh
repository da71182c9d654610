#!/usr/bin/env bash
# CI fuzz smoke (DESIGN section 9, docs/fuzzing.md): configures and builds the libFuzzer targets
# with clang-14 (-fsanitize=fuzzer,address,undefined; the libraries with
# -fsanitize=fuzzer-no-link,address,undefined) in build-fuzz-clang, then runs every
# target for SECONDS (default 30) from its seeds in corpus/fuzz/<target>/, two at a time.
# Any crash, sanitizer report, leak, timeout or out-of-memory fails with exit 1; the
# offending input is left in build-fuzz-clang/fuzz-smoke/<target>/ (crash-*, leak-*,
# timeout-*, oom-*) and the target's log next to it. New inputs go to a scratch folder,
# never into the repository. Works from a clean clone; builds only the fuzz targets.
#
# Every stored open finding (corpus/fuzz/open/<target>/ and its asan/ folder) is also
# run once: it must still fail; one that passes is reported as fixed and fails the smoke
# so the finding gets moved into the seed corpus.
#
# Usage: tools/fuzz-smoke.sh [SECONDS]
# Environment: VISGATE_FUZZ_BUILD (build dir, default <repo>/build-fuzz-clang),
#              JOBS (build jobs and targets run at once, default 2),
#              FUZZ_SMOKE_SEED (libFuzzer -seed, default 1),
#              FUZZ_SMOKE_SKIP (space-separated targets not to fuzz, e.g. while a
#              third-party finding is open; each skip is printed).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECS="${1:-30}"
BUILD="${VISGATE_FUZZ_BUILD:-$ROOT/build-fuzz-clang}"
JOBS="${JOBS:-2}"
TARGETS=(fuzz_scene_json fuzz_mesh_files fuzz_prepare fuzz_repair fuzz_iss fuzz_ssv fuzz_plucker fuzz_embree)

"$ROOT/fuzz/configure-clang.sh" "$BUILD"
start=$(date +%s)
cmake --build "$BUILD" -j "$JOBS" --target visgate_fuzzers
echo "fuzz-smoke: build took $(( $(date +%s) - start )) s" >&2

OUT="$BUILD/fuzz-smoke"
rm -rf "$OUT"
mkdir -p "$OUT"

# run_target NAME: runs one target for SECS seconds; returns its exit status.
run_target() {
  local t="$1" bin="$BUILD/fuzz/$1" dir="$OUT/$1"
  mkdir -p "$dir/new"
  # shellcheck disable=SC2207
  local opts=($("$ROOT/fuzz/options-flags.sh" "$ROOT/fuzz/$t.options"))
  local rc=0
  # A fixed seed (FUZZ_SMOKE_SEED, default 1): the runs start down the same mutation path,
  # but they part after a few thousand inputs (coverage depends on Embree's thread timing
  # and ISA), so a finding is reproduced from its input, printed below; campaigns use
  # random seeds.
  timeout -k 10 $(( SECS + 120 )) "$bin" "${opts[@]}" -seed="${FUZZ_SMOKE_SEED:-1}" -max_total_time="$SECS" -print_final_stats=1 \
    -artifact_prefix="$dir/" "$dir/new" "$ROOT/corpus/fuzz/$t" > "$dir/log" 2>&1 || rc=$?
  local execs
  execs=$(grep -E '^stat::number_of_executed_units' "$dir/log" | awk '{print $2}' || true)
  grep -m1 'NOTE Embree reported' "$dir/log" >&2 || true
  if [ "$rc" -eq 0 ]; then
    echo "fuzz-smoke: $t ok (${execs:-?} runs in ${SECS} s)" >&2
  else
    echo "fuzz-smoke: $t FAILED (exit $rc); log: $dir/log" >&2
    grep -E 'ERROR|MISMATCH|mismatch:|SUMMARY|Test unit written' "$dir/log" | head -20 >&2 || true
    # The input itself, base64: CI machines are thrown away, and libFuzzer's path through
    # the mutations is not reproducible elsewhere (a fixed -seed diverges after a few
    # thousand runs even on one machine: Embree's BVH build and our filter's coverage
    # differ by thread timing and ISA). Recreate it with `base64 -d > crash`.
    local f
    for f in "$dir"/crash-* "$dir"/leak-* "$dir"/timeout-* "$dir"/oom-*; do
      [ -f "$f" ] || continue
      echo "fuzz-smoke: $t input $(basename "$f") (base64, $(wc -c < "$f") bytes):" >&2
      base64 -w0 "$f" >&2
      echo >&2
    done
  fi
  return "$rc"
}

failed=0
# Stored open findings must still fail.
for t in "${TARGETS[@]}"; do
  [ -x "$BUILD/fuzz/$t" ] || continue
  for f in "$ROOT/corpus/fuzz/open/$t"/* "$ROOT/corpus/fuzz/open/$t"/asan/*; do
    [ -f "$f" ] || continue
    case "$f" in *.md|*.txt) continue ;; esac
    # shellcheck disable=SC2046
    if "$BUILD/fuzz/$t" $("$ROOT/fuzz/options-flags.sh" "$ROOT/fuzz/$t.options" | grep -v '^-dict=') -runs=1 "$f" \
        > "$OUT/open-$t-$(basename "$f").log" 2>&1; then
      echo "fuzz-smoke: open finding ${f#"$ROOT"/} now passes: fixed; move it into corpus/fuzz/$t/" >&2
      failed=1
    else
      echo "fuzz-smoke: open finding ${f#"$ROOT"/} still fails, as recorded" >&2
    fi
  done
done

pids=()
names=()
for t in "${TARGETS[@]}"; do
  if [ ! -x "$BUILD/fuzz/$t" ]; then
    echo "fuzz-smoke: $t not built in this tree (see fuzz/CMakeLists.txt); skipped" >&2
    continue
  fi
  if [[ " ${FUZZ_SMOKE_SKIP:-} " == *" $t "* ]]; then
    echo "fuzz-smoke: $t SKIPPED by FUZZ_SMOKE_SKIP" >&2
    continue
  fi
  run_target "$t" &
  pids+=($!)
  names+=("$t")
  if [ "${#pids[@]}" -ge "$JOBS" ]; then
    wait "${pids[0]}" || failed=1
    pids=("${pids[@]:1}")
    names=("${names[@]:1}")
  fi
done
for p in "${pids[@]}"; do wait "$p" || failed=1; done

echo "fuzz-smoke: total $(( $(date +%s) - start )) s" >&2
if [ "$failed" -ne 0 ]; then
  echo "fuzz-smoke: FAILED" >&2
  exit 1
fi
echo "fuzz-smoke: all targets ran ${SECS} s without a finding" >&2
