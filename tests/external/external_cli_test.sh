#!/usr/bin/env bash
# ctest ExternalMethods.CheckCli (tests/external/CMakeLists.txt): `visgate check` on external
# methods from the build tree. The textbook caster (examples/mt-caster) as a plugin is
# caught on shared-edge-fan (exit 1) and --store keeps its case minimised to at most 3
# triangles; a crashing plugin and a hanging exec: program are reported with exit 3,
# naming them, and brute's row is still in the report.
# Usage: external_cli_test.sh VISGATE MT_PLUGIN TEST_PLUGIN
set -euo pipefail
visgate="$1" mt="$2" test_plugin="$3"
work="$(mktemp -d /tmp/visgate-external-cli-XXXXXX)"
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

set +e
"$visgate" check --family shared-edge-fan --count 4 --tau 0 --no-metamorphic --methods "plugin:$mt" \
  --store "$work/store" --report "$work/report.json" 2>"$work/check.log"
rc=$?
set -e
[ "$rc" = 1 ] || { cat "$work/check.log" >&2; fail "check exited $rc, expected 1"; }
n=0
for f in $(find "$work/store" -name '*.json'); do
  tris=$(python3 -c "import json,sys; d=json.load(open(sys.argv[1])); print(sum(len(m['triangles']) for m in d['meshes']))" "$f")
  [ "$tris" -ge 1 ] && [ "$tris" -le 3 ] || fail "$f has $tris triangles"
  n=$((n + 1))
done
[ "$n" -ge 1 ] || fail "no case stored"

cp "$test_plugin" "$work/crashing.so"
printf '#!/bin/sh\nsleep 60\n' > "$work/hang.sh"
chmod +x "$work/hang.sh"
set +e
"$visgate" check --family random-soup --count 1 --no-metamorphic \
  --methods "plugin:$work/crashing.so,brute,exec:$work/hang.sh" \
  --opt "plugin:$work/crashing.so:mode=crash" --opt "exec:$work/hang.sh:timeout=1" \
  --report "$work/fail.json" 2>"$work/fail.log"
rc=$?
set -e
[ "$rc" = 3 ] || { cat "$work/fail.log" >&2; fail "check exited $rc, expected 3"; }
grep -q "plugin:$work/crashing.so: crashed: signal 11" "$work/fail.log" || fail "crash not named"
grep -q "exec:$work/hang.sh: timed out after 1 s" "$work/fail.log" || fail "timeout not named"
python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert any(x['method']=='brute' and x['relations']>0 for x in r['rows'])" \
  "$work/fail.json" || fail "brute's row is missing"
echo "external_cli_test: passed ($n stored case(s))"
