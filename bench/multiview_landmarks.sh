#!/usr/bin/env bash
# Scan landmarks on `scan synth` truth, side by side: the single front render (`landmarks scan --views 1`, the old
# method) against multi-view triangulation over N virtual cameras, before and after the landmark calibration (learned
# on the first scans, measured on the others: no scan is in both). Prints one row per configuration (median error
# over 17-67 and on the jaw contour, Spearman correlation of sigma with the error, seconds per scan) and, with a chart
# path, draws the speed-accuracy curve over N.
# Usage: bench/multiview_landmarks.sh [build/bin] [scans dir] [calibration scans] [views list] [chart.png]
set -euo pipefail
bin=${1:-build/bin}
scans=${2:-out/demo/scans}
ncal=${3:-5}
views=${4:-4 9 16 25}
chart=${5:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mapfile -t all < <(find "$scans" -mindepth 1 -maxdepth 1 -type d -exec test -f '{}/landmarks.json' ';' -print | sort)
mkdir -p "$work/cal"
for d in "${all[@]:0:$ncal}"; do ln -s "$(realpath "$d")" "$work/cal/"; done
tests=("${all[@]:$ncal}")
echo "calibration on ${ncal} scans, measured on ${#tests[@]}; $(nproc) cores"
evaluate() {  # evaluate LABEL VIEWS SECONDS files...
  local label=$1 n=$2 sec=$3
  shift 3
  local args=()
  for f in "$@"; do args+=("$(dirname "$f")/../truth_$(basename "$f" .json | sed 's/^[a-z0-9]*_//').json" "$f"); done
  /usr/bin/python3 bench/landmarks_eval.py "${args[@]}" | /usr/bin/python3 -c "
import json, sys
r = json.load(sys.stdin)
print(f'{\"$label\":<34} views {$n:>2} | 17-67 median {r[\"median_17_67\"]:5.2f} mm p90 {r[\"p90_17_67\"]:5.2f} | jaw {r[\"median_jaw\"]:5.2f} mm '
      f'| sigma~error {r[\"spearman_sigma_error\"]:5.2f} | {$sec:5.1f} s/scan | missing {r[\"missing\"]}')
with open('$work/rows.csv', 'a') as f:
    f.write(f'$label,$n,{r[\"median_17_67\"]},{r[\"median_jaw\"]},$sec\n')"
}
for t in "${tests[@]}"; do cp "$t/landmarks.json" "$work/truth_$(basename "$t").json"; done
mkdir -p "$work/out"
start=$(date +%s.%N)
for t in "${tests[@]}"; do "$bin/bareskin" -q landmarks scan "$t" --views 1 -o "$work/out/v1_$(basename "$t").json"; done
sec=$(echo "($(date +%s.%N) - $start) / ${#tests[@]}" | bc -l)
evaluate "anchor: single front render" 1 "$sec" "$work"/out/v1_*.json
for n in $views; do
  "$bin/bareskin" -q landmarks calibrate --scans "$work/cal" --views "$n" -o "$work/calib_$n.json"
  start=$(date +%s.%N)
  for t in "${tests[@]}"; do
    "$bin/bareskin" -q landmarks scan "$t" --views "$n" --calibration "$work/calib_$n.json" \
        --uncalibrated "$work/out/raw${n}_$(basename "$t").json" -o "$work/out/cal${n}_$(basename "$t").json"
  done
  sec=$(echo "($(date +%s.%N) - $start) / ${#tests[@]}" | bc -l)
  evaluate "multi-view uncalibrated" "$n" "$sec" "$work"/out/raw${n}_*.json
  evaluate "multi-view + calibration (ours)" "$n" "$sec" "$work"/out/cal${n}_*.json
done
if [ -n "$chart" ]; then
  cp "$work/rows.csv" "${chart%.png}.csv"
  /usr/bin/python3 bench/multiview_chart.py "${chart%.png}.csv" "$chart"
  echo "chart: $chart"
fi
