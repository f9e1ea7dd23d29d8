#!/usr/bin/env bash
# landmarks scan --capture on a synthetic capture: N renders of a textured `scan synth` scan from a ring of cameras
# (--save-views), then (1) real COLMAP on the photos (CPU; a folder it cannot reconstruct must give one line naming
# the fallback), and (2) the capture path on a COLMAP TXT model of the true cameras in an unknown frame
# (bench/capture_model.py): cameras recovered, their centres against the truth after alignment, landmarks against the
# scan's truth. Out of CI (COLMAP takes minutes on 2 cores).
# Usage: bench/capture.sh [build/bin] [scan dir] [calibration.json] [views]
set -euo pipefail
bin=${1:-build/bin}
scan=${2:-out/demo/scans/subject_0005}
calib=${3:-}
n=${4:-24}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cal=()
[ -n "$calib" ] && cal=(--calibration "$calib")
"$bin/bareskin" -q landmarks scan "$scan" --views "$n" --view-size 512 --save-views "$work/photos" -o "$work/virtual.json"
echo "== 1. COLMAP on $n renders"
start=$(date +%s)
"$bin/bareskin" landmarks scan "$scan" --views 16 "${cal[@]}" --capture "$work/photos" -o "$work/colmap.json" 2>&1 \
  | grep -E "COLMAP|falling back" || true
echo "   $(( $(date +%s) - start )) s"
echo "== 2. the capture path on a model of the true cameras in an unknown frame"
/usr/bin/python3 bench/capture_model.py "$work/photos/cameras.json" "$scan/mesh.obj" "$work/model"
"$bin/bareskin" landmarks scan "$scan" --views 16 "${cal[@]}" --capture "$work/photos" --sparse "$work/model" \
  -o "$work/capture.json" 2>&1 | grep -E "COLMAP" || true
/usr/bin/python3 - "$work" "$scan" <<'PY'
import json, sys
import numpy as np
w, scan = sys.argv[1:3]
truth = {c["image"]: c for c in json.load(open(f"{w}/photos/cameras.json"))["cameras"]}
doc = json.load(open(f"{w}/capture.json"))
cap = doc["capture"]
centre = lambda c: -np.array(c["R"]).T @ np.array(c["t"])
e = [np.linalg.norm(centre(c) - centre(truth[c["image"]])) for c in cap["cameras"]]
t = np.array(json.load(open(f"{scan}/landmarks.json"))["points"])
p = np.array(doc["points"], dtype=float)
d = np.linalg.norm(p - t, axis=1)
print(f"   cameras {cap['registered']} of {cap['photos']} ({100 * cap['registered'] / cap['photos']:.0f}%), centres "
      f"{np.median(e):.2f} mm median from the truth (max {max(e):.2f}); ICP RMS {cap['icp_rms_mm']:.2f} mm")
print(f"   landmarks vs truth: median {np.nanmedian(d):.2f} mm, 17-67 {np.nanmedian(d[17:]):.2f} mm, jaw {np.nanmedian(d[:17]):.2f} mm")
PY
