#!/usr/bin/env bash
# Fetches CGAL's example data (Debian package libcgal-demo: real scanned and modelled
# meshes such as the Stanford bunny at 75k triangles, the armadillo and the elephant)
# with `apt-get download` into a cache folder, never committed, and extracts its OFF
# meshes there for `visgate bench scan --families file:...` and the tests that skip
# when it is absent.
#
#   tools/fetch-cgal-data.sh [CACHE_DIR]   (default: .cache/cgal-data)
#
# Prints the folder of the meshes and how many there are.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
CACHE="${1:-$ROOT/.cache/cgal-data}"
mkdir -p "$CACHE"
cd "$CACHE"
if ! ls libcgal-demo_*.deb >/dev/null 2>&1; then
  apt-get download libcgal-demo
fi
deb="$(ls libcgal-demo_*.deb | head -n 1)"
rm -rf extracted meshes
mkdir -p extracted meshes
dpkg-deb -x "$deb" extracted
tar -xzf extracted/usr/share/doc/libcgal-dev/data.tar.gz -C extracted data/meshes
find extracted/data/meshes -maxdepth 1 -type f -name '*.off' -exec cp {} meshes/ \;
rm -rf extracted
echo "$CACHE/meshes: $(ls meshes | wc -l) OFF meshes"
