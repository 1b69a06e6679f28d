#!/usr/bin/env bash
# Installs Wake's build and test dependencies from Debian 12's packages (run as root).
# --clients also installs the programs the client tests open Wake's output with (Blender,
# ParaView's pvpython, and Xvfb for ParaView's rendering without a display).
# Skips apt entirely when everything is already there.
set -euo pipefail
# libboost-dev: OpenVDB 10's headers include Boost's, which libopenvdb-dev does not pull in.
packages=(cmake ninja-build g++ make pkg-config
  libeigen3-dev libbullet-dev libhdf5-dev nlohmann-json3-dev libcli11-dev
  libtinyobjloader-dev libgtest-dev libgmock-dev libbenchmark-dev
  libstb-dev libopenvdb-dev libboost-dev gnuplot-nox ccache)
if [ "${1:-}" = "--clients" ]; then
  packages+=(blender python3-paraview xvfb libgl1-mesa-dri)
fi
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
