#!/usr/bin/env bash
# ctest MemoryBudget.SolveCli (tests/base/CMakeLists.txt): `visgate solve` under a 1 MB
# memory budget on an 80k-triangle scan scene with 1024 receivers: every production
# method stops with exit 3, one line on stderr naming the method, the budget and the
# scene file, and no result file.
# Usage: memory_budget_cli_test.sh VISGATE
set -euo pipefail
visgate="$1"
work="$(mktemp -d /tmp/visgate-memory-budget-XXXXXX)"
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$visgate" gen scan --seed 1 --triangles 80000 --receivers 1024 --samples 4 -o "$work/scan.json" 2>/dev/null
for m in iss ssv plucker-bsp; do
  # iss would cast this scene's few relations per triangle as leaf rays (dense_rays),
  # holding no growing structure; its shafts are what the budget bounds.
  opt=()
  [ "$m" = iss ] && opt=(--opt dense_rays=off)
  set +e
  "$visgate" solve "$work/scan.json" --method "$m" "${opt[@]}" --threads 1 --memory-budget 1 -o "$work/$m.json" 2>"$work/$m.log"
  rc=$?
  set -e
  [ "$rc" = 3 ] || { cat "$work/$m.log" >&2; fail "$m exited $rc, expected 3"; }
  [ "$(wc -l < "$work/$m.log")" = 1 ] || { cat "$work/$m.log" >&2; fail "$m: not one line"; }
  grep -q "^visgate: $m stopped: .*memory budget of 1 MB.* on $work/scan.json\$" "$work/$m.log" ||
    { cat "$work/$m.log" >&2; fail "$m: message does not name method, budget and scene"; }
  [ ! -e "$work/$m.json" ] || fail "$m wrote a partial result"
done
echo "memory budget CLI: 3 passed, 0 failed"
