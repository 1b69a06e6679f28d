#!/usr/bin/env bash
# Installs Wake's build and test dependencies from Debian 12's packages (run as root).
# Skips apt entirely when everything is already there.
set -euo pipefail
packages=(cmake ninja-build g++ make pkg-config
  libeigen3-dev libbullet-dev libhdf5-dev nlohmann-json3-dev libcli11-dev
  libtinyobjloader-dev libgtest-dev libgmock-dev libbenchmark-dev
  libstb-dev gnuplot-nox)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "[wake] installing: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
