#!/usr/bin/env bash
# landmarks scan --capture with Debian's COLMAP (CPU) on a small synthetic rig capture (`landmarks capture`: 16
# photos at 384² of a `scan synth --skin-detail 1` scan, speckle backdrop) against the capture's true cameras: at
# least 90% of the photos registered, the aligned cameras project the scan's true landmarks where the true cameras
# do, and the landmarks found on the photos agree with the virtual views'. A folder COLMAP cannot reconstruct gives
# one warning naming the fallback (exit 0, output written); bad flags get one line and exit 3.
source "$(dirname "$0")/lib.sh" "$@"
export BARESKIN_ASSETS=${BARESKIN_ASSETS:-$here/../../assets}
command -v colmap > /dev/null || fail "colmap is not installed (Debian's colmap; make deps)"
"$bin" template -q --vertices 8000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 1 --vertices 30000 --res 1024 --skin-detail 1 -o "$work/scans" \
  || fail "scan synth"
scan=$work/scans/subject_0000
"$bin" landmarks capture -q "$scan" -o "$work/photos" --photos 16 --size 384 --field 260 --max-yaw 45 || fail "landmarks capture"
[ "$(ls "$work/photos"/photo_*.png | wc -l)" -eq 16 ] || fail "not 16 photos"

# 1. COLMAP's cameras against the truth. The rig's focal length is known and held fixed (rigs are calibrated; photos
# without EXIF leave COLMAP a guess 3x too short, and at this small yaw step its first pair then looks too narrow to
# start; refined from the true value it drifted to 1,096-1,602 px for 1,477, and one CI run failed the 4 px bound).
focal=$($py -c "import json; print(json.load(open('$work/photos/cameras.json'))['cameras'][0]['focal'])")
"$bin" landmarks scan "$scan" --views 8 --view-size 256 --capture "$work/photos" --colmap-features 1000 \
  --colmap-focal "$focal" \
  -o "$work/capture.json" 2> "$work/capture.log" || fail "landmarks scan --capture: $(cat "$work/capture.log")"
grep -q "falling back" "$work/capture.log" && fail "COLMAP did not reconstruct the capture: $(cat "$work/capture.log")"
"$bin" landmarks scan -q "$scan" --views 8 --view-size 256 -o "$work/virtual.json" || fail "landmarks scan --views"
$py - "$work" "$scan" <<'PY' || fail "the capture's cameras or landmarks are off"
import json, sys
import numpy as np
w, scan = sys.argv[1:3]
doc = json.load(open(f"{w}/capture.json"))
cap = doc["capture"]
true = {c["image"]: c for c in json.load(open(f"{w}/photos/cameras.json"))["cameras"]}
X = np.array(json.load(open(f"{scan}/landmarks.json"))["points"])[17:]
def project(c, X):
    p = X @ np.array(c["R"]).T + np.array(c["t"])
    return np.stack([c["cx"] + c["focal"] * p[:, 0] / -p[:, 2], c["cy"] - c["focal"] * p[:, 1] / -p[:, 2]], 1)
px = [np.linalg.norm(project(c, X) - project(true[c["image"]], X), axis=1).max() for c in cap["cameras"]]
lm = lambda f: np.array([[np.nan] * 3 if q is None else q for q in json.load(open(f))["points"]], dtype=float)
d = np.linalg.norm(lm(f"{w}/capture.json") - lm(f"{w}/virtual.json"), axis=1)[17:]
print(f"  {cap['registered']} of {cap['photos']} photos, {cap['points_on_head']} of {cap['points']} points on the head, "
      f"reprojection {cap['reprojection_px']:.2f} px, ICP RMS {cap['icp_rms_mm']:.2f} mm; true landmarks through the "
      f"aligned cameras: median of the worst per photo {np.median(px):.2f} px (photo width 384), camera NME "
      f"{cap['camera_nme']:.3f}; landmarks vs the virtual views' {np.nanmedian(d):.2f} mm")
assert cap["photos"] == 16 and cap["registered"] >= 15, cap["registered"]
assert cap["reprojection_px"] < 1 and cap["median_features"] > 300 and cap["points_on_head"] > 50
# The median over photos of the worst landmark's reprojection error: 2.2-2.3 px in most runs, 5.7 px in one full-suite
# run (COLMAP's mapping differs run to run, even on one thread); cameras 20 mm off put it near 29 px, so 8 px. One CI
# run had 26 px with the landmarks 4.9 mm off: the command now also checks its cameras (camera_nme, no truth needed;
# it refuses a model above 0.08 itself, so this test only checks that the JSON reports it) and runs COLMAP once more
# when they are off.
assert np.median(px) < 8, px
assert 0 < cap["camera_nme"] < float("inf"), cap
# COLMAP's multi-threaded mapping differs run to run (below 2 mm in most runs, 2.19 mm in one full-suite run), so the bound is the
# issue's 3 mm for capture landmarks (a misaligned model is tens of mm off).
assert np.nanmedian(d) < 3, d
PY

# 2. A folder COLMAP cannot reconstruct: three blank photos. One warning naming the fallback, exit 0, output.
mkdir -p "$work/blank"
for k in 1 2 3; do oiiotool --pattern constant:color=0.5,0.5,0.5 256x256 3 -d uint8 -o "$work/blank/p$k.png"; done
"$bin" landmarks scan -q "$scan" --views 8 --view-size 256 --capture "$work/blank" -o "$work/fallback.json" \
  2> "$work/fallback.log" || fail "the fallback failed: $(cat "$work/fallback.log")"
[ "$(grep -c . "$work/fallback.log")" -eq 1 ] && grep -q "COLMAP.*falling back to the 8 virtual views" "$work/fallback.log" \
  || fail "not one warning naming the fallback: $(cat "$work/fallback.log")"
[ -s "$work/fallback.json" ] && ! grep -q '"capture"' "$work/fallback.json" || fail "fallback output"

# 2b. A model whose points disagree with its cameras (a user's --sparse model of the true cameras, its points shifted
# 20 mm: ICP fits the points, so the cameras land 20 mm off, as in a distorted COLMAP run): one warning naming the
# fallback, exit 0, output without the capture.
$py "$here/../../bench/capture_model.py" "$work/photos/cameras.json" "$scan/mesh.obj" "$work/sparse" --points 2000 \
  > /dev/null || fail "capture_model.py"
$py - "$work/sparse/points3D.txt" <<'PY' || fail "shift the points"
import sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
for f in rows:
    f[1] = "%.9g" % (float(f[1]) + 0.0137 * 20)  # capture_model.py's frame: 0.0137 model units per mm
open(sys.argv[1], "w").write("".join(" ".join(f) + "\n" for f in rows))
PY
"$bin" landmarks scan -q "$scan" --views 8 --view-size 256 --capture "$work/photos" --sparse "$work/sparse" \
  -o "$work/distorted.json" 2> "$work/distorted.log" || fail "the distorted model's fallback failed: $(cat "$work/distorted.log")"
grep -q "the model is distorted; falling back to the 8 virtual views" "$work/distorted.log" \
  || fail "no warning naming the distorted model's fallback: $(cat "$work/distorted.log")"
[ -s "$work/distorted.json" ] && ! grep -q '"capture"' "$work/distorted.json" || fail "distorted model's output"

# 3. Bad input: one line, exit 3, no output.
expect_failure 3 "is not a folder" "$work/bad.json" -- "$bin" landmarks scan -q "$scan" --views 4 \
  --capture "$work/nothing" -o "$work/bad.json"
expect_failure 3 "several views" "$work/bad.json" -- "$bin" landmarks scan -q "$scan" --capture "$work/photos" \
  -o "$work/bad.json"
expect_failure 3 "needs --capture" "$work/bad.json" -- "$bin" landmarks scan -q "$scan" --views 4 \
  --sparse "$work/photos" -o "$work/bad.json"
expect_failure 3 "--photos" "$work/badcap" -- "$bin" landmarks capture -q "$scan" --photos 1 -o "$work/badcap"
echo "landmarks_capture: all passed"
