#!/usr/bin/env bash
# Plots of a run's time series (DIR/series.csv, columns in io/series.hpp) with gnuplot:
#
#   bash scripts/plot.sh DIR [--svg]
#
# writes DIR/plots/heights.png (every moving body's centre-of-mass height y over time),
# velocities.png (their vertical velocity vy and speed |v|), density_ratio.png (largest
# density / rest density) and penetrating.png (fluid centres inside a body after a step).
# Scenes without moving bodies get only the last two. --svg writes the same as .svg too.
# Needs gnuplot (Debian: apt-get install gnuplot-nox).
set -euo pipefail

fail() {
  echo "plot.sh: error: $*" >&2
  exit 1
}

dir=""
svg=0
for arg in "$@"; do
  case "$arg" in
    --svg) svg=1 ;;
    -h | --help)
      sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'
      exit 0
      ;;
    -*) fail "unknown option $arg (usage: scripts/plot.sh DIR [--svg])" ;;
    *)
      [[ -z "$dir" ]] || fail "one folder only (usage: scripts/plot.sh DIR [--svg])"
      dir="$arg"
      ;;
  esac
done
[[ -n "$dir" ]] || fail "usage: scripts/plot.sh DIR [--svg] (DIR: the --out folder of wake run)"
command -v gnuplot >/dev/null 2>&1 ||
  fail "gnuplot is not installed (Debian: apt-get install gnuplot-nox)"
csv="$dir/series.csv"
[[ -f "$csv" ]] || fail "$csv does not exist (run: wake run SCENE.json --out $dir)"

IFS=',' read -r -a columns <"$csv" || true
[[ "${#columns[@]}" -ge 5 && "${columns[0]}" == "time" ]] ||
  fail "$csv: not a Wake series (the header must start with time,max_density_ratio,...)"

# The scene's name for the titles: DIR/<scene>.h5, else the folder's name.
scene="$(basename "$dir")"
shopt -s nullglob
h5=("$dir"/*.h5)
[[ "${#h5[@]}" -eq 1 ]] && scene="$(basename "${h5[0]}" .h5)"

# Column number (1-based) of each name.
declare -A col
for i in "${!columns[@]}"; do
  col["${columns[$i]}"]=$((i + 1))
done
bodies=()
for name in "${columns[@]}"; do
  if [[ "$name" == *.y ]]; then
    body="${name%.y}"
    [[ -n "${col[$body.vx]:-}" && -n "${col[$body.vy]:-}" && -n "${col[$body.vz]:-}" ]] &&
      bodies+=("$body")
  fi
done

# gnuplot single-quoted string: a quote is doubled.
quote() { printf "'%s'" "${1//\'/\'\'}"; }

mkdir -p "$dir/plots"
out="$dir/plots"
script="$(mktemp)"
trap 'rm -f "$script"' EXIT

{
  echo "set datafile separator ','"
  echo "set datafile missing 'nan'"
  echo "set grid lc rgb '#dddddd'"
  echo "set key outside right top"
  echo "set xlabel 'time t (s)'"
  echo "data = $(quote "$csv")"
  formats=("pngcairo noenhanced size 960,540 font 'sans,11'|png")
  [[ "$svg" -eq 1 ]] && formats+=("svg noenhanced size 960,540 font 'sans,11' background rgb 'white'|svg")
  for format in "${formats[@]}"; do
    terminal="${format%|*}"
    ext="${format#*|}"
    echo "set terminal $terminal"
    if [[ "${#bodies[@]}" -gt 0 ]]; then
      echo "set output $(quote "$out/heights.$ext")"
      echo "set title $(quote "$scene: height of each body's centre of mass")"
      echo "set ylabel 'y (m)'"
      plot="plot"
      sep=" "
      for j in "${!bodies[@]}"; do
        body="${bodies[$j]}"
        plot+="$sep data using 1:${col[$body.y]} with lines lw 2 lc $((j + 1))"
        plot+=" title $(quote "$body.y")"
        sep=", "
      done
      echo "$plot"

      echo "set output $(quote "$out/velocities.$ext")"
      echo "set title $(quote "$scene: vertical velocity and speed of each body")"
      echo "set ylabel 'velocity (m/s)'"
      plot="plot"
      sep=" "
      for j in "${!bodies[@]}"; do
        body="${bodies[$j]}"
        vx=${col[$body.vx]}
        vy=${col[$body.vy]}
        vz=${col[$body.vz]}
        plot+="$sep data using 1:$vy with lines lw 2 lc $((j + 1)) title $(quote "$body.vy")"
        sep=", "
        plot+="$sep data using 1:(sqrt(\$$vx**2 + \$$vy**2 + \$$vz**2))"
        plot+=" with lines lw 1 dt 2 lc $((j + 1))"
        plot+=" title $(quote "$body speed |v|")"
      done
      echo "$plot"
    fi

    echo "set output $(quote "$out/density_ratio.$ext")"
    echo "set title $(quote "$scene: largest density / rest density")"
    echo "set ylabel 'max density ratio (1)'"
    echo "plot data using 1:${col[max_density_ratio]} with linespoints lw 2 pt 7 ps 0.5" \
      "title 'max_density_ratio'"

    echo "set output $(quote "$out/penetrating.$ext")"
    echo "set title $(quote "$scene: fluid centres inside a body (0 is the guarantee)")"
    echo "set ylabel 'particles (count)'"
    # A count that stays 0 gets the range [0, 1] instead of gnuplot's warning.
    echo "stats data using ${col[penetrating]}:${col[lost_particles]} nooutput"
    echo "set yrange [0:(STATS_max_x > STATS_max_y ? STATS_max_x : STATS_max_y) * 1.1 + 1]"
    echo "plot data using 1:${col[penetrating]} with steps lw 2 title 'penetrating'," \
      "data using 1:${col[lost_particles]} with steps lw 1 dt 2 title 'lost_particles'"
    echo "unset yrange"
    echo "set output"
  done
} >"$script"

gnuplot "$script" || fail "gnuplot failed on $csv"
echo "plots in $out/:"
for f in "$out"/*.png "$out"/*.svg; do
  echo "  $(basename "$f")"
done
