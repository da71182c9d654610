#!/usr/bin/env bash
# CI check of the installed package (docs/external-methods.md): installs the built
# visgate into a clean prefix, then, against that prefix only,
#   1. builds the example method (examples/mt-caster: a textbook float Möller-Trumbore
#      caster as an exec: program and a plugin) with find_package(visgate);
#   2. builds and runs the consumer's own GoogleTest suite (examples/consumer:
#      find_package(visgate REQUIRED), the oracle through visgate/visgate.h and
#      visgate/testing.h);
#   3. runs the installed `visgate check --family shared-edge-fan --count 4` on the caster
#      as exec: and plugin:, expects its errors found (exit 1) and --store to keep cases
#      of at most 3 triangles for both;
#   4. expects a crashing plugin and a hanging exec: method to be reported with exit 3
#      naming them, with the other method's row still in the report.
# Needs a finished build (tools/build.sh). Usage: tools/ci-install-example.sh [PREFIX]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VISGATE_BUILD_DIR:-$root/build}"
prefix="${1:-/tmp/visgate-prefix}"
work="$(mktemp -d /tmp/visgate-ci-example-XXXXXX)"
trap 'rm -rf "$work"' EXIT
fail() { echo "ci-install-example: FAIL: $*" >&2; exit 1; }
t0=$(date +%s)

rm -rf "$prefix"
cmake --install "$build" --prefix "$prefix" >/dev/null
[ -f "$prefix/lib/cmake/visgate/visgateConfig.cmake" ] || fail "no visgateConfig.cmake in $prefix"
[ -f "$prefix/include/visgate/visgate.h" ] || fail "no include/visgate/visgate.h in $prefix"
visgate="$prefix/bin/visgate"

# 1 and 2: the example method and the consumer, against the prefix alone.
cmake -S "$root/examples/mt-caster" -B "$work/mt" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" >/dev/null
cmake --build "$work/mt" -j2 >/dev/null
exec_m="exec:$work/mt/mt_caster_exec"
plugin_m="plugin:$work/mt/libmt_caster_plugin.so"
cmake -S "$root/examples/consumer" -B "$work/consumer" -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH="$prefix" \
  -DMT_CASTER_PLUGIN="$work/mt/libmt_caster_plugin.so" >/dev/null
cmake --build "$work/consumer" -j2 >/dev/null
ctest --test-dir "$work/consumer" --output-on-failure >&2 || fail "the consumer's tests"

# 3: check finds the caster's errors and stores them minimised.
set +e
"$visgate" check --family shared-edge-fan --count 4 --tau 0 --no-metamorphic --methods "$exec_m,$plugin_m" \
  --store "$work/store" --report "$work/report.json" 2>"$work/check.log"
rc=$?
set -e
[ "$rc" = 1 ] || { cat "$work/check.log" >&2; fail "check on the textbook caster exited $rc, expected 1"; }
python3 - "$work/store" "$work/report.json" <<'PY' || fail "stored cases"
import json, pathlib, sys
store, report = pathlib.Path(sys.argv[1]), json.load(open(sys.argv[2]))
methods = {m["method"] for m in report["mismatches"] if m["kind"] == "oracle"}
assert any(m.startswith("exec:") for m in methods) and any(m.startswith("plugin:") for m in methods), methods
cases = list(store.rglob("*.json"))
assert cases, "no case stored"
stored_methods = set()
for c in cases:
    d = json.load(open(c))
    tris = sum(len(m.get("triangles", [])) for m in d["meshes"])
    print(f"{c.relative_to(store)}: {tris} triangles, {d['case']['method'].split('/')[-1]}, "
          f"{d['case'].get('direction', '?')}", file=sys.stderr)
    assert 1 <= tris <= 3, (c, tris)
    stored_methods.add(d["case"]["method"].split(":")[0])
assert stored_methods == {"exec", "plugin"}, stored_methods
PY

# 4: a crashing plugin and a hanging program are failures of those methods (exit 3),
# and brute's row is still in the report.
cat > "$work/hang.sh" <<'SH'
#!/bin/sh
sleep 60
SH
chmod +x "$work/hang.sh"
cat > "$work/crash.cpp" <<'CPP'
#include <visgate/plugin.h>
static int solve(void*, const visgate_scene_v1_t*, const visgate_option_v1_t*, size_t, uint64_t, int,
                 visgate_output_v1_t*) { volatile int* p = nullptr; return *p; }
static const visgate_method_v1_t m = {VISGATE_METHOD_ABI_VERSION, 0, "crash", nullptr, 0, nullptr, solve, nullptr};
extern "C" const visgate_method_v1_t* visgate_method_v1(void) { return &m; }
CPP
c++ -shared -fPIC -I"$prefix/include" "$work/crash.cpp" -o "$work/libcrash.so"
set +e
"$visgate" check --family random-soup --count 1 --no-metamorphic \
  --methods "plugin:$work/libcrash.so,brute,exec:$work/hang.sh" --opt "exec:$work/hang.sh:timeout=2" \
  --report "$work/fail.json" 2>"$work/fail.log"
rc=$?
set -e
[ "$rc" = 3 ] || { cat "$work/fail.log" >&2; fail "check with a crashing plugin exited $rc, expected 3"; }
grep -q "plugin:$work/libcrash.so: crashed: signal 11" "$work/fail.log" || fail "the crash is not named"
grep -q "exec:$work/hang.sh: timed out after 2 s" "$work/fail.log" || fail "the timeout is not named"
python3 -c "import json,sys; r=json.load(open(sys.argv[1])); assert any(x['method']=='brute' and x['relations']>0 for x in r['rows'])" \
  "$work/fail.json" || fail "brute's row is missing"

echo "ci-install-example: passed in $(( $(date +%s) - t0 )) s (prefix $prefix)" >&2
