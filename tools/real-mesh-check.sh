#!/usr/bin/env bash
# Checks iss, ssv and plucker-bsp against the exact oracle (metamorphic checks included)
# on a `file:` scene of every real mesh: CGAL's example meshes and OpenSCAD's regression
# STLs (fetched by tools/fetch-*.sh, never committed), or the meshes given. Meshes the
# loader rejects count as rejected (exit 2 with its one-line message), not as failures.
#
#   tools/real-mesh-check.sh VISGATE OUTDIR [MESH...]
#
# Writes OUTDIR/<mesh>.json (the check report) and .err (its table), prints one line per
# mesh and a total; exits 1 when a method disagrees with the oracle or a check fails.
set -uo pipefail
[ $# -ge 2 ] || { echo "usage: $0 VISGATE OUTDIR [MESH...]" >&2; exit 2; }
bin=$1 out=$2
shift 2
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
meshes=("$@")
if [ ${#meshes[@]} -eq 0 ]; then
  cgal="$("$ROOT/tools/fetch-cgal-data.sh" | tail -n 1 | sed 's/: [0-9]* OFF meshes$//')" || cgal=""
  scad="$("$ROOT/tools/fetch-openscad-data.sh" | tail -n 1 | sed 's/: [0-9]* STL files$//')" || scad=""
  [ -n "$cgal" ] && meshes+=("$cgal"/*.off)
  [ -n "$scad" ] && meshes+=("$scad"/*.stl)
  [ ${#meshes[@]} -gt 0 ] || { echo "real-mesh-check: no meshes fetched" >&2; exit 2; }
fi
mkdir -p "$out"
checked=0 rejected=0 failed=0
for m in "${meshes[@]}"; do
  b=$(basename "$m")
  "$bin" check --family "file:$m" --count 1 --receivers 25 --samples 8 --methods iss,ssv,plucker-bsp \
    --threads 1 --report "$out/$b.json" >/dev/null 2>"$out/$b.err"
  rc=$?
  case $rc in
    0) checked=$((checked + 1)); echo "$b: $(grep -h '^total:' "$out/$b.err")" ;;
    2) rejected=$((rejected + 1)); echo "$b: rejected: $(head -n 1 "$out/$b.err")" ;;
    *) failed=$((failed + 1)); echo "$b: FAILED (exit $rc): $(grep -h '^total:' "$out/$b.err" || tail -n 1 "$out/$b.err")" ;;
  esac
done
echo "real-mesh-check: ${#meshes[@]} meshes: $checked checked without a mismatch, $rejected rejected as bad input, $failed failed"
[ "$failed" -eq 0 ]
