#!/usr/bin/env bash
# Installs dependencies, builds Wake and plays the default demo scene headless:
# a dam break in a tank, written to out/dam_break/ (HDF5 + XDMF for ParaView, summary.json,
# series.csv), with PNG frames (out/dam_break/frames/) and plots (out/dam_break/plots/).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
BUILD_DIR=build bash scripts/build.sh
./build/io/wake run scenes/dam_break.json --out out/dam_break "$@"
./build/io/wake render out/dam_break --every 3
bash scripts/plot.sh out/dam_break
echo "[wake] output in out/dam_break:"; ls -l out/dam_break
cat out/dam_break/summary.json
