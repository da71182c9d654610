#!/usr/bin/env bash
# Installs the Debian 12 packages visgate needs (DESIGN section 9), non-interactively.
# Idempotent and fast when everything is present: only missing packages are installed.
set -euo pipefail
packages=(
  build-essential cmake pkg-config git
  libcgal-dev libgmp-dev libmpfr-dev libboost-dev
  libopenmesh-dev libembree-dev libtbb-dev
  libgtest-dev libcli11-dev nlohmann-json3-dev libfmt-dev libstb-dev
  gnuplot-nox clang-14 libclang-rt-14-dev
)
missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present" >&2
  exit 0
fi
echo "setup: installing ${missing[*]}" >&2
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done" >&2
