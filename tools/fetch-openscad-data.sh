#!/usr/bin/env bash
# Fetches OpenSCAD's regression data (Debian package openscad-testing-data: CAD bug
# report meshes with back-to-back faces, zero-area triangles and bad exports) with
# `apt-get download` into a cache folder, never committed, and extracts its STL files
# there for tests/repair/openscad_meshes_test.cpp (RepairOpenScad.*), which skip when it is absent.
#
#   tools/fetch-openscad-data.sh [CACHE_DIR]   (default: .cache/openscad-testing-data)
#
# Prints the folder of the STL files and how many there are.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
CACHE="${1:-$ROOT/.cache/openscad-testing-data}"
mkdir -p "$CACHE"
cd "$CACHE"
if ! ls openscad-testing-data_*.deb >/dev/null 2>&1; then
  apt-get download openscad-testing-data
fi
deb="$(ls openscad-testing-data_*.deb | head -n 1)"
rm -rf extracted stl
mkdir -p extracted stl
dpkg-deb -x "$deb" extracted
# Flattened names: the path below the package's data folder, '/' turned into '__'.
find extracted -type f -iname '*.stl' | sort | while read -r f; do
  rel="${f#extracted/}"
  cp "$f" "stl/${rel//\//__}"
done
echo "$CACHE/stl: $(ls stl | wc -l) STL files"
