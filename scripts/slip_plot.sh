#!/usr/bin/env bash
# README's slip plot: the fronts on the three ramps of scenes/slip_ramp.json
# (slip 0, 0.5, 1) over time, at the scene's own (CFL) step and with time.max_dt forcing
# a step 4x smaller, into demos/gallery/slip_ramp_fronts.png (and the CSVs beside it in
# out/slip_plot/).
#
#   bash scripts/slip_plot.sh   (needs build/; about 3 minutes on 2 cores)
#
# Needs gnuplot (Debian: apt-get install gnuplot-nox).
set -euo pipefail
cd "$(dirname "$0")/.."
fronts=./build/demos/wake_slip_fronts
[[ -x "$fronts" ]] || { echo "slip_plot.sh: error: build first (bash scripts/build.sh)" >&2; exit 1; }
command -v gnuplot >/dev/null 2>&1 ||
  { echo "slip_plot.sh: error: gnuplot is not installed (apt-get install gnuplot-nox)" >&2; exit 1; }
scene=scenes/slip_ramp.json
out=out/slip_plot
mkdir -p "$out" demos/gallery

# The scene's own step: its mean step decides the forced one.
"$fronts" "$scene" >"$out/cfl.csv" 2>"$out/cfl.log"
mean=$(sed -n 's/.*mean step \([0-9.e+-]*\) s.*/\1/p' "$out/cfl.log")
[[ -n "$mean" ]] || { echo "slip_plot.sh: error: no mean step in $out/cfl.log" >&2; exit 1; }
small=$(awk -v m="$mean" 'BEGIN { printf "%.4g", m / 4 }')
"$fronts" "$scene" "$small" >"$out/small.csv" 2>"$out/small.log"
echo "[slip_plot] CFL step: $(cat "$out/cfl.log"); max_dt $small s: $(cat "$out/small.log")"

gnuplot <<GNUPLOT
set datafile separator ','
set terminal pngcairo noenhanced size 960,540 font 'sans,11'
set output 'demos/gallery/slip_ramp_fronts.png'
set grid lc rgb '#dddddd'
set key top left
set title 'slip_ramp: front travel down a 25 degree ramp, nu = 1e-3 m^2/s'
set xlabel 'time t (s)'
set ylabel 'front travel (m)'
plot for [k=2:4] '$out/cfl.csv' using 1:k with lines lw 2 lc k-1 \
       title sprintf('slip %s, CFL step (%s s)', word('0 0.5 1', k-1), '$mean'), \
     for [k=2:4] '$out/small.csv' using 1:k with points pt 7 ps 0.6 lc k-1 \
       title sprintf('slip %s, max_dt %s s', word('0 0.5 1', k-1), '$small')
GNUPLOT
echo "[slip_plot] demos/gallery/slip_ramp_fronts.png"
