#!/usr/bin/env bash
# landmarks detect against face-api's own JavaScript (node, tfjs CPU; skipped without node) on astronaut.png and on
# a render of a synthetic scan: same faces, scores within 1e-3, points within 0.5 px. Grey, 16-bit and 8K photos
# work; landmarks scan + scan register without landmarks.json work on a synthetic scan; bad input (not an image, a
# tiny image, no face, truncated weights, a manifest of another model) gets one line, exit 3, and no output.
source "$(dirname "$0")/lib.sh" "$@"
assets=${BARESKIN_ASSETS:-$here/../../assets}
export BARESKIN_ASSETS=$assets
passed=0
ok() { passed=$((passed + 1)); }
astronaut=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
[ -f "$astronaut" ] || fail "$astronaut missing (Debian python3-skimage; make deps)"

compare() {  # compare OURS.json REFERENCE.json
  /usr/bin/python3 - "$1" "$2" <<'PY'
import json, sys
import numpy as np
ours, ref = (json.load(open(p)) for p in sys.argv[1:3])
assert len(ours["faces"]) == len(ref["faces"]) > 0, (len(ours["faces"]), len(ref["faces"]))
for o, r in zip(ours["faces"], ref["faces"]):
    ds = abs(o["score"] - r["score"])
    dp = np.abs(np.array(o["points"]) - np.array(r["points"])).max()
    db = np.abs(np.array(o["box"]) - np.array(r["box"])).max()
    print(f"  score {o['score']:.4f} vs {r['score']:.4f}, max point difference {dp:.4f} px, box {db:.4f} px")
    assert ds <= 1e-3 and dp <= 0.5 and db <= 0.5, (ds, dp, db)
PY
}

# 1. Oracle: astronaut.png and a render of a synthetic scan.
"$bin" landmarks detect -q "$astronaut" -o "$work/astro.json" --draw "$work/astro.png" || fail "detect astronaut"
[ -s "$work/astro.png" ] || fail "no drawing"
"$bin" template -q --vertices 8000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 1 --vertices 30000 --res 512 -o "$work/scans" || fail "scan synth"
scan=$work/scans/subject_0000
"$bin" render -q "$scan/mesh.obj" --texture "$scan/diffuse.png" --camera pinhole --size 512 -o "$work/render.png" \
  || fail "render"
"$bin" landmarks detect -q "$work/render.png" --min-score 0.1 -o "$work/render.json" || fail "detect render"
if command -v node > /dev/null; then
  for name in astro render; do
    src=$astronaut
    [ $name = render ] && src=$work/render.png
    min=0.5
    [ $name = render ] && min=0.1
    oiiotool "$src" --ch R,G,B -d uint8 -o "$work/$name.ppm" || fail "ppm"
    node "$here/../node/face_api_reference.mjs" "$assets/face_api" "$work/$name.ppm" 416 $min 2> "$work/node.err" \
      > "$work/$name.ref.json" || fail "node reference: $(tail -3 "$work/node.err")"
    compare "$work/$name.json" "$work/$name.ref.json" || fail "$name differs from face-api's JavaScript"
    ok
  done
else
  echo "  node not installed: the face-api oracle is skipped"
fi

# 2. Grey, 16-bit and 8K photos give the same landmarks (within resampling).
oiiotool "$astronaut" --chsum:weight=.2126,.7152,.0722 -d uint8 -o "$work/grey.png"
oiiotool "$astronaut" -d uint16 -o "$work/sixteen.png"
oiiotool "$astronaut" --resize 8192x8192 -o "$work/huge.jpg"
for name in grey sixteen huge; do
  file=$work/$name.png
  [ $name = huge ] && file=$work/huge.jpg
  "$bin" landmarks detect -q "$file" -o "$work/$name.json" || fail "$name photo"
done
/usr/bin/python3 - "$work" <<'PY' || fail "grey/16-bit/8K disagree"
import json, sys
import numpy as np
w = sys.argv[1]
base = np.array(json.load(open(f"{w}/astro.json"))["points"])
for name, scale, tol in (("sixteen", 1, 0.05), ("grey", 1, 3.0), ("huge", 16, 1.5)):
    p = np.array(json.load(open(f"{w}/{name}.json"))["points"]) / scale
    d = np.linalg.norm(p - base, axis=1)
    print(f"  {name}: median {np.median(d):.3f} px, max {d.max():.3f} px from the 8-bit RGB result")
    assert np.median(d) <= tol, name
PY
ok

# 3. A scan without landmarks.json: landmarks from its render, then registration.
"$bin" landmarks scan -q "$scan" -o "$work/scan_lm.json" --draw "$work/scan_lm.png" || fail "landmarks scan"
/usr/bin/python3 - "$work/scan_lm.json" "$scan/landmarks.json" <<'PY' || fail "scan landmarks far from truth"
import json, sys
import numpy as np
d, t = (np.array(json.load(open(p))["points"]) for p in sys.argv[1:3])
e = np.linalg.norm(d - t, axis=1)
print(f"  scan landmarks vs truth: median {np.median(e):.2f} mm (inner 51: {np.median(e[17:]):.2f} mm)")
assert np.median(e[17:]) < 10, e
PY
mv "$scan/landmarks.json" "$work/truth_landmarks.json"
"$bin" scan register -q --template "$work/t" --scans "$work/scans" -o "$work/registered" --maps-res 0 \
  || fail "register without landmarks.json"
grep -q '"detected' "$work/registered/subject_0000/report.json" || fail "report does not say landmarks were detected"
ok

# 4. Bad input: one line, exit 3, no output.
expect_error() {  # expect_error NAME NEEDLE args...
  local name=$1 needle=$2
  shift 2
  expect_failure 3 "$needle" "$work/bad_$name.json" -- "$bin" landmarks detect -q "$@" -o "$work/bad_$name.json"
  ok
}
echo "not an image" > "$work/text.png"
expect_error text "text.png" "$work/text.png"
oiiotool "$astronaut" --resize 48x48 -o "$work/tiny.png"
expect_error tiny "64x64" "$work/tiny.png"
oiiotool --pattern constant:color=0.5,0.5,0.5 256x256 3 -d uint8 -o "$work/blank.png"
expect_error noface "no face" "$work/blank.png"
mkdir -p "$work/w1" "$work/w2"
cp "$assets"/face_api/*.json "$work/w1/" && cp "$assets"/face_api/*.bin "$work/w1/"
head -c 100000 "$assets/face_api/face_landmark_68_model.bin" > "$work/w1/face_landmark_68_model.bin"
expect_error truncated "truncated" "$astronaut" --weights "$work/w1"
cp "$assets"/face_api/*.bin "$work/w2/"
cp "$assets/face_api/face_landmark_68_model-weights_manifest.json" "$work/w2/"
cp "$assets/face_api/face_landmark_68_model-weights_manifest.json" "$work/w2/tiny_face_detector_model-weights_manifest.json"
expect_error mismatch "another model" "$astronaut" --weights "$work/w2"

# 5. Multi-view landmarks: calibrated on two synthetic scans, measured on a third (truth: its landmarks.json); bad
# input to the multi-view options gets one line and exit 3.
"$bin" scan synth -q --template "$work/t" --count 3 --vertices 30000 --res 512 -o "$work/mv" || fail "scan synth (3)"
mkdir -p "$work/mvcal" && ln -s "$work/mv/subject_0000" "$work/mv/subject_0001" "$work/mvcal/"
"$bin" landmarks calibrate -q --scans "$work/mvcal" --views 6 --view-size 256 -o "$work/calib.json" || fail "calibrate"
"$bin" landmarks scan -q "$work/mv/subject_0002" --views 6 --view-size 256 --calibration "$work/calib.json" \
  --uncalibrated "$work/mv_raw.json" -o "$work/mv_lm.json" --draw "$work/mv.png" || fail "landmarks scan --views"
"$bin" landmarks scan -q "$work/mv/subject_0002" -o "$work/sv_lm.json" || fail "landmarks scan (single view)"
/usr/bin/python3 - "$work" <<'PY' || fail "multi-view landmarks far from truth"
import json, sys
import numpy as np
w = sys.argv[1]
t = np.array(json.load(open(f"{w}/mv/subject_0002/landmarks.json"))["points"])
err = lambda f: np.linalg.norm(np.array(json.load(open(f))["points"], dtype=float) - t, axis=1)
mv, sv = err(f"{w}/mv_lm.json"), err(f"{w}/sv_lm.json")
sigma = np.array([d["sigma_mm"] for d in json.load(open(f"{w}/mv_lm.json"))["detail"]])
print(f"  multi-view + calibration: 17-67 median {np.median(mv[17:]):.2f} mm, jaw {np.median(mv[:17]):.2f} mm; "
      f"single view {np.median(sv[17:]):.2f} / {np.median(sv[:17]):.2f} mm")
assert np.isfinite(mv).all() and (sigma > 0).all()
assert np.median(mv[17:]) < 3 and np.median(mv[17:]) < 0.7 * np.median(sv[17:]), (mv, sv)
assert np.median(mv[:17]) < 0.5 * np.median(sv[:17])
PY
ok
expect_failure 3 "calibration" "$work/bad_mv.json" -- "$bin" landmarks scan -q "$work/mv/subject_0002" --views 4 \
  --calibration "$work/mv/subject_0002/landmarks.json" -o "$work/bad_mv.json"
ok
expect_failure 3 "several views" "$work/bad_mv.json" -- "$bin" landmarks scan -q "$work/mv/subject_0002" \
  --calibration "$work/calib.json" -o "$work/bad_mv.json"
ok
expect_failure 3 "two or more" "$work/bad_cal.json" -- "$bin" landmarks calibrate -q --scans "$work/mv" --count 1 \
  --views 4 -o "$work/bad_cal.json"
ok
echo "$passed passed, 0 failed"
