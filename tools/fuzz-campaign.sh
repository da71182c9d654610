#!/usr/bin/env bash
# Fuzzing campaign for one target (docs/fuzzing.md): builds the clang libFuzzer
# targets in build-fuzz-clang (fuzz/configure-clang.sh), runs TARGET for SECONDS with
# libFuzzer's -fork over every core (crashes, timeouts and OOMs are collected, not
# fatal), merges the inputs that add coverage into the seed corpus corpus/fuzz/TARGET/,
# and turns every crash into a stored case:
#   1. libFuzzer minimises the crashing input (-minimize_crash);
#   2. differential targets: when `visgate minimize` exists it reads the crash file
#      through the fuzz decoder and writes the minimal corpus entry under corpus/;
#   3. otherwise (and for the input targets) the minimised input is stored as an open
#      finding in corpus/fuzz/open/TARGET/ with a note holding the report's first lines;
#      ctest checks it keeps failing until it is fixed (fuzz/CMakeLists.txt).
# Findings in third-party code (Embree, OpenMesh) stay open; say so in the note.
#
# Usage: tools/fuzz-campaign.sh TARGET SECONDS
# Environment: VISGATE_FUZZ_BUILD (default <repo>/build-fuzz-clang), JOBS (fork workers,
#              default: all cores), VISGATE (the visgate binary, default
#              <repo>/build/tools/visgate if present, else `visgate` on PATH).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
TARGET="${1:?usage: tools/fuzz-campaign.sh TARGET SECONDS}"
SECS="${2:?usage: tools/fuzz-campaign.sh TARGET SECONDS}"
BUILD="${VISGATE_FUZZ_BUILD:-$ROOT/build-fuzz-clang}"
JOBS="${JOBS:-$(nproc)}"
SEEDS="$ROOT/corpus/fuzz/$TARGET"
OPEN="$ROOT/corpus/fuzz/open/$TARGET"

"$ROOT/fuzz/configure-clang.sh" "$BUILD"
cmake --build "$BUILD" -j 2 --target "$TARGET"
BIN="$BUILD/fuzz/$TARGET"

WORK="$BUILD/campaign/$TARGET-$(date -u +%Y%m%dT%H%M%SZ)"
mkdir -p "$WORK/corpus" "$WORK/artifacts" "$SEEDS"
# shellcheck disable=SC2207
OPTS=($("$ROOT/fuzz/options-flags.sh" "$ROOT/fuzz/$TARGET.options"))

echo "fuzz-campaign: $TARGET for $SECS s on $JOBS workers; work dir $WORK" >&2
"$BIN" "${OPTS[@]}" -fork="$JOBS" -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
  -max_total_time="$SECS" -print_final_stats=1 -artifact_prefix="$WORK/artifacts/" \
  "$WORK/corpus" "$SEEDS" > "$WORK/fuzz.log" 2>&1 || true
grep -E '^#[0-9]+: cov:|INFO: fuzzed for|stat::' "$WORK/fuzz.log" | tail -3 >&2 || true

# Merge: only inputs that add coverage to the seed corpus are copied into it.
before=$(find "$SEEDS" -maxdepth 1 -type f | wc -l)
"$BIN" "${OPTS[@]}" -merge=1 "$SEEDS" "$WORK/corpus" > "$WORK/merge.log" 2>&1 || {
  echo "fuzz-campaign: merge failed, see $WORK/merge.log" >&2
}
after=$(find "$SEEDS" -maxdepth 1 -type f | wc -l)
echo "fuzz-campaign: seed corpus $before -> $after inputs" >&2

# The visgate CLI, for `visgate minimize` on differential findings.
VG="${VISGATE:-}"
if [ -z "$VG" ]; then
  if [ -x "$ROOT/build/tools/visgate" ]; then VG="$ROOT/build/tools/visgate"; else VG="$(command -v visgate || true)"; fi
fi
METHOD=""
case "$TARGET" in
  fuzz_iss) METHOD=iss ;;
  fuzz_ssv) METHOD=ssv ;;
  fuzz_plucker) METHOD=plucker-bsp ;;
  fuzz_embree) METHOD=embree-robust ;;
esac
have_minimize=0
if [ -n "$METHOD" ] && [ -n "$VG" ] && "$VG" minimize --help > /dev/null 2>&1; then have_minimize=1; fi

found=0
for a in "$WORK"/artifacts/crash-* "$WORK"/artifacts/timeout-* "$WORK"/artifacts/oom-* "$WORK"/artifacts/leak-*; do
  [ -f "$a" ] || continue
  found=$((found + 1))
  name="$(basename "$a")"
  min="$WORK/artifacts/min-$name"
  if [[ "$name" == crash-* || "$name" == leak-* ]]; then
    "$BIN" "${OPTS[@]}" -minimize_crash=1 -runs=20000 -exact_artifact_path="$min" "$a" > "$WORK/minimize-$name.log" 2>&1 || true
  fi
  [ -f "$min" ] || cp "$a" "$min"
  report="$WORK/report-$name.log"
  rerun=0
  "$BIN" "${OPTS[@]}" -runs=1 "$min" > "$report" 2>&1 || rerun=$?
  # A timeout or OOM that does not recur on its own was the load of the moment (libFuzzer's
  # -timeout is wall time; a niced campaign on a busy machine gets a fraction of a core):
  # reported, not stored (an open finding must keep failing, tools/fuzz-smoke.sh).
  if [[ "$name" == timeout-* || "$name" == oom-* ]] && [ "$rerun" -eq 0 ]; then
    echo "fuzz-campaign: $name does not recur when run alone (load-induced; see $report); not stored" >&2
    continue
  fi
  if [ "$have_minimize" -eq 1 ]; then
    entry="$("$VG" minimize "$min" --method "$METHOD" -o "$ROOT/corpus" 2>> "$report" || true)"
    if [ -n "$entry" ]; then
      echo "fuzz-campaign: $name -> corpus entry $entry written by visgate minimize (see $report)" >&2
      continue
    fi
    echo "fuzz-campaign: visgate minimize wrote no entry for $name (no mismatch it can minimise: a crash, or a fraction error without a lattice witness); storing it as an open finding" >&2
  fi
  mkdir -p "$OPEN"
  sha="$(sha1sum "$min" | cut -c1-40)"
  cp "$min" "$OPEN/$sha"
  {
    echo "# $TARGET finding $sha (open)"
    echo
    echo "Found by tools/fuzz-campaign.sh $TARGET $SECS on $(date -u +%Y-%m-%d); kind: ${name%%-*}."
    echo "Reproduce: $TARGET corpus/fuzz/open/$TARGET/$sha (clang build) or the replay binary."
    echo "Status: open. Replace this line with the diagnosis; move the file into"
    echo "corpus/fuzz/$TARGET/ once fixed."
    echo
    echo '```'
    grep -E 'ERROR|MISMATCH|mismatch:|method:|options:|exception|SUMMARY|Assertion|fuzz_' "$report" |
      grep -vE '^ *#[0-9]|^Running|Running 1 inputs' | head -20
    echo '```'
  } > "$OPEN/$sha.md"
  echo "fuzz-campaign: $name -> open finding corpus/fuzz/open/$TARGET/$sha (+ .md note)" >&2
done
echo "fuzz-campaign: $TARGET done: $found finding(s); log $WORK/fuzz.log" >&2
