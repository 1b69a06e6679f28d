#!/usr/bin/env bash
# README's gallery, made with Wake's own commands: plays every demo scene in
# scenes/ at its default resolution and surfaces the water (wake run --surface), draws
# one chosen frame of each, the water as its surface mesh (wake render), into
# demos/gallery/<scene>.png and plots the time series of a few
# (scripts/plot.sh) into demos/gallery/<scene>_<plot>.png.
#
#   bash scripts/gallery.sh [--reuse] [SCENE...]   (default: every scene; needs build/)
#
# The runs go to out/gallery/<scene>/ (--reuse: keep a finished run there and only draw).
# Takes about 10 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
wake=./build/io/wake
[[ -x "$wake" ]] || { echo "gallery.sh: error: build first (bash scripts/build.sh)" >&2; exit 1; }

# The time (s) of the still for each scene: the moment that shows what the scene is about.
declare -A still=(
  [stone_skipping]=0.2 [stone_skipping_local]=0.2 [impact]=0.1 [slip_ramp]=0.3
  [buoyancy]=1.2 [drag_low]=0.6 [drag_high]=0.6 [sinking_ship]=1.5
  [sinking_ship_penalty]=1.5 [vessel]=1.0 [flotsam]=0.7 [dam_break]=0.5 [floating_box]=1.0
  [honey_and_water]=0.3 [squeeze]=0.2
)
# Camera per scene (default --view iso); --section cuts the fluid open so that bodies
# under water show.
declare -A look=(
  [buoyancy]="--view front --section" [drag_low]="--view front --section"
  [drag_high]="--view front --section" [sinking_ship]="--view front --section"
  [sinking_ship_penalty]="--view front --section" [vessel]="--view iso --section"
  [floating_box]="--view iso --section" [slip_ramp]="--view top" [honey_and_water]="--view top" [impact]="--view front --section"
  [squeeze]="--view front --section"
)

reuse=0
scenes=()
for arg in "$@"; do
  if [[ "$arg" == --reuse ]]; then reuse=1; else scenes+=("$arg"); fi
done
if ((${#scenes[@]} == 0)); then
  for f in scenes/*.json; do scenes+=("$(basename "$f" .json)"); done
fi
mkdir -p demos/gallery
for name in "${scenes[@]}"; do
  out=out/gallery/$name
  if ((reuse == 0)) || [[ ! -f "$out/summary.json" ]]; then
    "$wake" run "scenes/$name.json" --out "$out" --surface --quiet
  elif [[ ! -f "$out/surface/surface.json" ]]; then
    "$wake" surface "$out" --quiet
  fi
  rate=$(sed -n 's/.*"frame_rate": *\([0-9.]*\).*/\1/p' "scenes/$name.json" | head -1)
  t=${still[$name]:-0.5}
  frame=$(awk -v t="$t" -v r="$rate" 'BEGIN { printf "%d", t * r + 0.5 }')
  # shellcheck disable=SC2086 # the look is a list of options
  "$wake" render "$out" --frames "$frame" --width 640 --height 360 \
    ${look[$name]:---view iso} --out "$out/still" --quiet
  cp "$out/still/$(printf '%s_%06d.png' "$name" "$frame")" "demos/gallery/$name.png"
  echo "[gallery] demos/gallery/$name.png (t = $t s)"
done
# Plots where a curve says more than a picture.
for name in stone_skipping buoyancy sinking_ship sinking_ship_penalty; do
  [[ -d out/gallery/$name ]] || continue
  bash scripts/plot.sh "out/gallery/$name" >/dev/null
  for p in heights density_ratio penetrating; do
    [[ -f out/gallery/$name/plots/$p.png ]] && cp "out/gallery/$name/plots/$p.png" "demos/gallery/${name}_$p.png"
  done
done
echo "[gallery] done"
