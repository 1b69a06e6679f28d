#!/usr/bin/env bash
# Both pressure solvers on the paper's scenes (README "Choosing a solver"): each scene's
# first SIM_TIME simulated seconds with fluid.solver "wcsph" (the scene as it is) and
# "dfsph", one Markdown row per scene and solver: fluid particles, steps, wall seconds per
# simulated second, ns per particle per step, the divergence-free solver's iterations per
# step (density + divergence), the density error (average over the steps of the average
# compression, the worst step's average, the largest single density ratio) and whether
# any fluid entered a body.
#
#   [DFSPH_MAX_DT=DT] bench/solvers.sh [BUILD_DIR] [SIM_TIME] [THREADS] [SCENE.json...]
#
# Defaults: build, 0.2 s, 2 threads, the scenes below; DFSPH_MAX_DT (s) is the
# divergence-free runs' max_dt (wake_bench_solvers --dfsph-max-dt; its own default if unset). Time it on a quiet machine (no
# builds or other runs beside it): about 10 minutes with the defaults.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
sim_time=${2:-0.2}
threads=${3:-2}
shift $(($# < 3 ? $# : 3))
scenes=("$@")
if [ ${#scenes[@]} -eq 0 ]; then
  scenes=(scenes/dam_break.json scenes/buoyancy.json scenes/floating_box.json
          scenes/stone_skipping.json scenes/sinking_ship.json scenes/vessel.json
          scenes/impact.json scenes/drag_low.json)
fi
bench="$build/bench/wake_bench_solvers"
[ -x "$bench" ] || { echo "error: $bench not found (build Wake first)" >&2; exit 2; }

echo "| scene | solver | fluid particles | steps | wall s per simulated s | ns/particle/step | iterations per step (density + divergence) | avg density error | worst step | largest density ratio | fluid in a body |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for scene in "${scenes[@]}"; do
  extra=()
  if [ -n "${DFSPH_MAX_DT:-}" ]; then extra=(--dfsph-max-dt "$DFSPH_MAX_DT"); fi
  out=$("$bench" --scene "$scene" --sim-time "$sim_time" --threads "$threads" "${extra[@]}")
  echo "$out" | awk -v scene="$(basename "$scene" .json)" '
    $1 == "wcsph" || $1 == "dfsph" {
      its = ($1 == "dfsph") ? sprintf("%.2f + %.2f", $7, $8) : ""
      printf "| %s | %s | %d | %d | %.1f | %.0f | %s | %.3f %% | %.3f %% | %.3f | %s |\n",
             scene, $1, $2, $3, $5, $6, its, 100 * $10, 100 * $11, $12, ($13 > 0 ? "yes" : "no")
    }'
done
echo
echo "($bench, first $sim_time simulated s of each scene, $threads threads)"
