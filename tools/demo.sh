#!/usr/bin/env bash
# The main job: set up, build, then run the correctness gate on the built-in suite,
# printing its table and writing its report and stability chart to out/gate/.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/tools/setup.sh"
"$root/tools/build.sh"
"${VISGATE_BUILD_DIR:-$root/build}/tools/visgate" gate "$@" -o "$root/out/gate"
