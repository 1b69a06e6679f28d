#!/usr/bin/env bash
# The fluid step's speed table (README "Speed"): the dam-break benchmark at 100k, 1M and
# 2.5M fluid particles and the SPHERIC-2 scene (bench/spheric2.json) at 100k, each on 1 and
# 2 threads. Prints one Markdown row per run: particles, ns per particle per step on 1 and
# 2 threads, the speed-up, the peak resident memory per fluid particle, and the split of
# the one-thread step (neighbours, density, forces, boundary, integration, in %).
#
#   bench/run.sh [BUILD_DIR] [SIZES]     e.g. bench/run.sh build "100000 1000000"
#
# BENCH_ARGS adds options to every run, e.g. BENCH_ARGS="--skin 0" (neighbour lists built
# every step, as before the skin).
#
# Time it on a quiet machine (no builds or other runs beside it): about 5 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
sizes=${2:-100000 1000000 2500000}
bench="$build/bench/wake_bench_dambreak"
[ -x "$bench" ] || { echo "error: $bench not found (build Wake first)" >&2; exit 2; }

row() {  # row LABEL ARGS...: one benchmark run, one table row
  local label=$1
  shift
  local out
  # shellcheck disable=SC2086  # BENCH_ARGS: words on purpose
  out=$("$bench" --threads 1,2 "$@" ${BENCH_ARGS:-})
  echo "$out" | awk -v label="$label" '
    $1 == "1" && NF >= 13 { n = $2; one = $6; split_ = sprintf("%s / %s / %s / %s / %s", $7, $8, $9, $10, $11) }
    $1 == "2" && NF >= 13 { two = $6 }
    /peak resident memory/ { bytes = $(NF - 4) }
    END { printf "| %s | %d | %.0f | %.0f | %.2fx | %d | %s |\n", label, n, one, two, one / two, bytes, split_ }'
}

echo "| scene | fluid particles | ns/particle/step, 1 thread | 2 threads | speed-up | peak bytes/particle | 1-thread split: neighbours / density / forces / boundary / integration [%] |"
echo "|---|---|---|---|---|---|---|"
for n in $sizes; do
  case $n in
    *000000 | 2500000) steps=8 warmup=2 ;;
    *) steps=30 warmup=10 ;;
  esac
  row "dam break (synthetic)" --particles "$n" --steps "$steps" --warmup "$warmup"
done
row "SPHERIC-2 (bench/spheric2.json)" --scene bench/spheric2.json --steps 30 --warmup 10
echo
echo "$(git rev-parse --short HEAD 2>/dev/null || echo '?'), $(nproc) cores: $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //')"
