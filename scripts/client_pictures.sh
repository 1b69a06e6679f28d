#!/usr/bin/env bash
# The README's pictures of a frame in Blender and in ParaView, made by the client tests'
# own scripts (tests/clients/) on a larger run than the tests use: the floating box
# scene, surfaced, its frame at t = 0.5 s.
#   bash scripts/client_pictures.sh      (needs build/, blender, pvpython, Xvfb)
set -euo pipefail
cd "$(dirname "$0")/.."
wake=./build/io/wake
out=out/client_pictures
$wake run scenes/floating_box.json --out "$out" --end 0.5 --surface --quiet
frame=$(( $(ls "$out"/surface/fluid_*.ply | wc -l) - 1 ))
blender -b --factory-startup -noaudio --python tests/clients/blender_check.py -- \
  "$out/surface" "$frame" demos/gallery/client_blender.png | grep blender_check
tests/clients/with_xvfb.sh pvpython tests/clients/paraview_check.py "$out" \
  floating_box demos/gallery/client_paraview.png 2>/dev/null | grep paraview_check
