#!/usr/bin/env bash
# The settling sphere (scenes/settling_sphere.json, or another scene with one dynamic
# sphere named "sphere" in a tank): runs it and plots the sphere's sinking speed over time
# beside the terminal speed of the standard drag law: Stokes' drag with the
# Schiller-Naumann correction, C_D = 24/Re (1 + 0.15 Re^0.687), times the wall factor of
# Di Felice (1996) for a sphere of diameter d in a tube of diameter D,
# ((1 - d/D) / (1 - 0.33 d/D))^((3.3 + 0.085 Re) / (1 + 0.1 Re)); a tank of square
# section (its narrower side W) counts as a tube of D = W 2.1044 / 1.903, the ratio of
# the first-order Stokes wall coefficients of a tube and a square duct (Happel and
# Brenner 1965), as the Settling test (tests/physics/test_coupled_bodies.cpp) does.
#
#   bash scripts/settling_plot.sh [SCENE] [--no-run | wake run options...]
#
# writes out/settling_sphere/ (the run) and out/settling_sphere/plots/settling_speed.png
# (--no-run: the plot of the run already there).
# Needs build/ and gnuplot (Debian: apt-get install gnuplot-nox). The default scene takes
# about 10 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
fail() {
  echo "settling_plot.sh: error: $*" >&2
  exit 1
}
wake=./build/io/wake
[[ -x "$wake" ]] || fail "build first (bash scripts/build.sh)"
command -v gnuplot >/dev/null 2>&1 || fail "gnuplot is not installed (apt-get install gnuplot-nox)"
scene=scenes/settling_sphere.json
if [[ $# -gt 0 && "$1" != -* ]]; then
  scene=$1
  shift
fi
[[ -f "$scene" ]] || fail "no scene $scene"
name=$(basename "$scene" .json)
out=out/$name
if [[ "${1:-}" == --no-run ]]; then
  [[ -f "$out/series.csv" ]] || fail "no run in $out (run without --no-run first)"
else
  "$wake" run "$scene" --out "$out" "$@"
fi

# The drag law's terminal speed from the scene's own numbers.
read -r stokes terminal reynolds < <(python3 - "$scene" <<'PY'
import json, math, sys
scene = json.load(open(sys.argv[1]))
fluid = scene["fluid"]
rho_f = fluid.get("rest_density", 1000.0)
nu = fluid.get("kinematic_viscosity", 1e-6)
g = math.sqrt(sum(c * c for c in scene.get("gravity", [0, -9.81, 0])))
sphere = next(b for b in scene["bodies"] if b["name"] == "sphere")
tank = next(b for b in scene["bodies"] if b["shape"]["type"] == "tank")["shape"]
d = 2 * sphere["shape"]["radius"]
rho_s = sphere["density"]
width = min(tank["max"][0] - tank["min"][0], tank["max"][2] - tank["min"][2])
lam = d / (width * 2.1044 / 1.903)
stokes = (rho_s - rho_f) * g * d * d / (18 * rho_f * nu)
u = stokes
for _ in range(200):  # fixed point of the force balance
    re = u * d / nu
    wall = ((1 - lam) / (1 - 0.33 * lam)) ** ((3.3 + 0.085 * re) / (1 + 0.1 * re))
    u = 0.5 * u + 0.5 * stokes * wall / (1 + 0.15 * re ** 0.687)
print(f"{stokes:.3g} {u:.3g} {u * d / nu:.2g}")
PY
)
echo "[settling_plot] drag law: terminal speed $terminal m/s (Re $reynolds; Stokes alone $stokes m/s)"
mkdir -p "$out/plots"
gnuplot <<GNUPLOT
set datafile separator ','
set terminal pngcairo noenhanced size 960,540 font 'sans,11'
set output '$out/plots/settling_speed.png'
set grid lc rgb '#dddddd'
set key top right
set title '$name: the sphere sinking speed against the drag law'
set xlabel 'time t (s)'
set ylabel 'sinking speed -v_y (m/s)'
set xzeroaxis lt -1
plot '$out/series.csv' using 'time':(-column('sphere.vy')) with lines lw 2 title 'Wake', \
     $terminal with lines lw 2 dt 2 title 'Stokes + Schiller-Naumann + wall ($terminal m/s, Re $reynolds)', \
     $stokes with lines lw 1 dt 3 title 'Stokes alone ($stokes m/s)'
GNUPLOT
echo "[settling_plot] $out/plots/settling_speed.png"
