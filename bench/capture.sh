#!/usr/bin/env bash
# landmarks scan --capture on synthetic rig captures, against the truth (bench/capture_eval.py): one `scan synth`
# subject (2K maps, 0.2 mm noise, open nostrils) with and without --skin-detail, photographed by `landmarks
# capture` (PHOTOS photos at SIZE², 3 rows, yaw ±70°) with and without the speckle backdrop; COLMAP on each (CPU),
# the model aligned to the scan, landmarks triangulated on the photos and calibrated. Beside them: the virtual
# views alone (--views 16) and the capture path on the true cameras (bench/capture_model.py: COLMAP's part taken
# out). Out of CI (COLMAP's matching takes minutes on 2 cores).
# Usage: bench/capture.sh [build/bin] [out dir] [calibration.json] [size] [photos]
#   calibration: `bareskin landmarks calibrate --scans out/demo/scans --count 5 -o calib16.json` (docs/cli.md)
set -euo pipefail
bin=${1:-build/bin}
out=${2:-out/bench_capture}
calib=${3:-}
size=${4:-1024}
photos=${5:-24}
py=/usr/bin/python3
mkdir -p "$out"
cal=()
[ -n "$calib" ] && cal=(--calibration "$calib")
for skin in plain detail; do
  detail=0
  [ $skin = detail ] && detail=1
  [ -d "$out/scans_$skin/subject_0000" ] || "$bin/bareskin" -q scan synth -o "$out/scans_$skin" --count 1 --seed 7 \
    --res 2048 --truth-res 0 --holes --noise 0.2 --skin-detail $detail
done
row() {  # row LABEL SCAN CAPTURE [landmarks scan flags...]
  local label=$1 scan=$2 capture=$3
  shift 3
  local start=$(date +%s.%N)
  "$bin/bareskin" landmarks scan "$scan" --views 16 "${cal[@]}" "$@" -o "$out/$label.json" 2> "$out/$label.log" \
    || { echo "$label: failed (see $out/$label.log)"; return; }
  local secs=$(echo "$(date +%s.%N) - $start" | bc)
  grep -E "falling back" "$out/$label.log" | sed 's/^/   /' || true
  $py bench/capture_eval.py "$out/$label.json" "$capture" "$scan" --label "$label" --json "$out/$label.eval.json" \
    | sed "s/\$/  ($(printf '%.0f' "$secs") s)/"
}
echo "== $photos photos at ${size}², COLMAP 3.8 on the CPU (cameras registered, reprojection, head points, ICP, camera centres vs truth, landmarks vs truth)"
for skin in plain detail; do
  for back in none speckle; do
    cap=$out/capture_${skin}_${back}_$size
    flags=()
    [ $back = none ] && flags=(--no-backdrop)
    [ -f "$cap/cameras.json" ] || "$bin/bareskin" -q landmarks capture "$out/scans_$skin/subject_0000" -o "$cap" \
      --photos "$photos" --size "$size" "${flags[@]}"
    row "colmap_${skin}_${back}_$size" "$out/scans_$skin/subject_0000" "$cap" --capture "$cap"
  done
done
cap=$out/capture_detail_speckle_$size
row "virtual_views_16" "$out/scans_detail/subject_0000" "$cap"
$py bench/capture_model.py "$cap/cameras.json" "$out/scans_detail/subject_0000/mesh.obj" "$out/true_model_$size" > /dev/null
row "true_cameras_$size" "$out/scans_detail/subject_0000" "$cap" --capture "$cap" --sparse "$out/true_model_$size"
