#!/usr/bin/env bash
# Prints the [libfuzzer] settings of a fuzz/<target>.options file as libFuzzer flags
# (-key=value, one per line; `dict` made absolute relative to the options file), the way
# OSS-Fuzz and ClusterFuzzLite apply them. Used by tools/fuzz-smoke.sh and
# tools/fuzz-campaign.sh.
#
# Usage: fuzz/options-flags.sh fuzz/<target>.options
set -euo pipefail
f="${1:?usage: fuzz/options-flags.sh OPTIONS_FILE}"
[ -f "$f" ] || exit 0
dir="$(cd "$(dirname "$f")" && pwd)"
awk -v dir="$dir" '
  /^\[/ { section = $0; next }
  section == "[libfuzzer]" && /=/ {
    split($0, kv, "=")
    k = kv[1]; v = substr($0, index($0, "=") + 1)
    gsub(/^[ \t]+|[ \t]+$/, "", k); gsub(/^[ \t]+|[ \t]+$/, "", v)
    if (k == "dict" && substr(v, 1, 1) != "/") v = dir "/" v
    print "-" k "=" v
  }' "$f"
