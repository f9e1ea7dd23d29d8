#!/usr/bin/env bash
# scan register on `scan synth` truth: accuracy and time per scan, our default (NICP on ~2k nodes with the consistency
# stiffness, blended onto the dense template) side by side with the anchor, Amberg's NICP as published (one affine per
# template vertex, his stiffness term), across node counts and schedules, and against measurement noise. Usage: bench/register.sh [build/bin] [template dir] [scans per row] [chart.png]
# Prints one row per configuration and, with a chart path, draws error against time (the speed-accuracy curve).
set -euo pipefail
bin=${1:-build/bin}
template=${2:-out/demo/template}
count=${3:-3}
chart=${4:-}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
[ -f "$template/face.obj" ] || "$bin/bareskin" template -q -o "$template"
row() {  # row LABEL NOISE register-args...
  local label=$1 noise=$2
  shift 2
  [ -d "$work/scans_$noise" ] || "$bin/bareskin" scan synth -q --template "$template" --count "$count" --res 0 \
      --noise "$noise" --rotation-jitter 10 --translation-jitter 30 --holes -o "$work/scans_$noise"
  rm -rf "$work/reg"
  "$bin/bareskin" scan register -q --template "$template" --scans "$work/scans_$noise" -o "$work/reg" --maps-res 0 "$@"
  /usr/bin/python3 - "$work/reg/summary.json" "$label" "$noise" "$work/rows.csv" <<'PY'
import json, sys, statistics as st
rows = json.load(open(sys.argv[1]))["scans"]
m = lambda key, q: st.median(r[key][q] for r in rows)
import csv
with open(sys.argv[4], "a", newline="") as f:
    csv.writer(f).writerow([sys.argv[2], sys.argv[3], m("correspondence_error_mm", "median"),
                            m("correspondence_error_mm", "p95"), st.median(r["seconds"]["total"] for r in rows)])
print(f"{sys.argv[2]:<28} noise {float(sys.argv[3]):.1f} mm | corr median {m('correspondence_error_mm','median'):.3f} "
      f"p95 {m('correspondence_error_mm','p95'):.3f} | surface median {m('surface_distance_mm','median'):.3f} | "
      f"landmarks {m('landmark_error_mm','mean'):.2f} | {st.median(r['seconds']['total'] for r in rows):5.1f} s/scan")
PY
}
echo "$count scans per row, $(nproc) cores, template $(grep -c '^v ' "$template/face.obj") vertices"
amberg="--consistency 0 --affine-stiffness 1 --stiffness 20 10 5 2 1 0.5 --landmark-weight 30 20 10 5 2 1 --tangential-weight 0 0 0 0 0 0"
row "ours (default)" 0
row "anchor: Amberg NICP per vertex" 0 --nodes 0 $amberg
row "Amberg term on 2k nodes" 0 $amberg
row "ours, 4k nodes" 0 --nodes 4000
row "ours, 8k nodes" 0 --nodes 8000
row "ours, stiffness x2" 0 --stiffness 8 4 2 0.8 0.1 0.02
row "ours, stiffness /2" 0 --stiffness 2 1 0.5 0.2 0.025 0.005
row "ours, 1 iteration/step" 0 --iterations 1
for noise in 0.1 0.3 0.5; do row "ours (default)" $noise; done
if [ -n "$chart" ]; then
  cp "$work/rows.csv" "${chart%.png}.csv"
  /usr/bin/python3 bench/register_chart.py "${chart%.png}.csv" "$chart"
  echo "chart: $chart"
fi
