#!/usr/bin/env bash
# Sets up, builds and runs every test suite with ctest.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/setup.sh"
# Third-party meshes for the repair and real-mesh tests (never committed); without them those tests skip.
"$root/tools/fetch-openscad-data.sh" >&2 || echo "test: OpenSCAD regression meshes not fetched; RepairOpenScad tests skip" >&2
"$root/tools/fetch-cgal-data.sh" >&2 || echo "test: CGAL's example meshes not fetched; RealMeshes tests skip" >&2
"$root/tools/build.sh"
cd "${VISGATE_BUILD_DIR:-$root/build}"
ctest --output-on-failure -j "$(nproc)"
