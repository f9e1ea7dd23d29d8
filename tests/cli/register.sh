#!/usr/bin/env bash
# scan register through the command line: a population registers with errors against the truth and transferred maps;
# a scan in metres, a mirrored scan and a fragment each get one line naming the problem (exit 3, nothing written for that scan);
# --keep-going registers the rest and lists the failures; without landmarks the fallback is flagged. Scans as users
# bring them (quads, fewer maps, another folder) are tests/cli/third_party.sh.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 2 --vertices 8000 --res 128 --truth-res 64 -o "$work/s" || fail "synth"
reg() { "$bin" scan register -q --template "$work/t" --maps-res 64 "$@"; }

reg --scans "$work/s" -o "$work/r" || fail "register"
$py - "$work/r/summary.json" <<'PY' || fail "summary"
import json, sys
rows = json.load(open(sys.argv[1]))["scans"]
assert len(rows) == 2, rows
for r in rows:
    assert r["alignment"].startswith("landmarks"), r["alignment"]
    assert r["correspondence_error_mm"]["median"] < 2.5, r["correspondence_error_mm"]
    assert r["surface_distance_mm"]["median"] < 0.05, r["surface_distance_mm"]
    assert r["maps"]["vs_truth"]["normal_angle_median_deg"] < 5, r["maps"]
PY
for f in mesh.ply diffuse.png normal.png roughness.png specular.png qa_front.png report.json; do
  [ -f "$work/r/subject_0000/$f" ] || fail "missing $f"
done
oiiotool --info "$work/r/subject_0000/normal.png" | grep -q "64 x  *64, 3 channel, uint16 png" || fail "transferred normal map"

# Broken copies of subject_0000.
broken() {  # broken NAME: a copy of subject_0000 in its own population folder
  mkdir -p "$work/b_$1" && cp -r "$work/s/subject_0000" "$work/b_$1/subject_0000"
  echo "$work/b_$1"
}
metres=$(broken metres)
$py - "$metres/subject_0000" <<'PY'
import json, sys
d = sys.argv[1]
lines = []
for line in open(d + "/mesh.obj"):
    if line.startswith("v "):
        x = [float(t) * 0.001 for t in line.split()[1:4]]
        line = "v %.9g %.9g %.9g\n" % tuple(x)
    lines.append(line)
open(d + "/mesh.obj", "w").writelines(lines)
lm = json.load(open(d + "/landmarks.json"))
lm["points"] = [[c * 0.001 for c in p] for p in lm["points"]]
json.dump(lm, open(d + "/landmarks.json", "w"))
PY
mirrored=$(broken mirrored)
$py - "$mirrored/subject_0000" <<'PY'
import json, sys
d = sys.argv[1]
lines = []
for line in open(d + "/mesh.obj"):
    if line.startswith("v ") or line.startswith("vn "):
        t = line.split()
        t[1] = repr(-float(t[1]))
        line = " ".join(t) + "\n"
    lines.append(line)
open(d + "/mesh.obj", "w").writelines(lines)
lm = json.load(open(d + "/landmarks.json"))
lm["points"] = [[-p[0], p[1], p[2]] for p in lm["points"]]
json.dump(lm, open(d + "/landmarks.json", "w"))
PY
fragment=$(broken fragment)  # only the triangles within 15 mm of the nose tip; the landmarks as they were
$py - "$fragment/subject_0000" <<'PY'
import json, sys
import numpy as np
d = sys.argv[1]
lines = open(d + "/mesh.obj").readlines()
V = np.array([[float(t) for t in l.split()[1:4]] for l in lines if l.startswith("v ")])
tip = np.array(json.load(open(d + "/landmarks.json"))["points"][30])
near = np.linalg.norm(V - tip, axis=1) < 15
keep = lambda l: not l.startswith("f ") or all(near[int(t.split("/")[0]) - 1] for t in l.split()[1:])
open(d + "/mesh.obj", "w").writelines(l for l in lines if keep(l))
PY
for name in metres mirrored fragment; do
  expect_failure 3 "$name" "$work/out_$name" -- reg --scans "$work/b_$name" -o "$work/out_$name"  # no folder left
done

# --keep-going: the good scans register, the broken ones are listed, exit 3.
mkdir -p "$work/mixed"
cp -r "$work/s/subject_0001" "$work/mixed/"
cp -r "$metres/subject_0000" "$work/mixed/subject_0002"
cp -r "$mirrored/subject_0000" "$work/mixed/subject_0003"
reg --scans "$work/mixed" -o "$work/out_mixed" --keep-going 2> "$work/err"
[ $? -eq 3 ] || fail "keep-going exit code"
[ -f "$work/out_mixed/subject_0001/report.json" ] || fail "keep-going did not register the good scan"
$py -c "import json,sys; s=json.load(open(sys.argv[1])); assert len(s['failures']) == 2 and len(s['scans']) == 1, s['failures']" \
  "$work/out_mixed/summary.json" || fail "keep-going summary"

# --no-landmarks: the documented fallback, flagged in the report (without the flag, a scan lacking landmarks.json
# gets detected ones: tests/cli/landmarks.sh).
mkdir -p "$work/nolm" && cp -r "$work/s/subject_0001" "$work/nolm/" && rm "$work/nolm/subject_0001/landmarks.json"
"$bin" scan register -q --no-landmarks --template "$work/t" --maps-res 0 --scans "$work/nolm" -o "$work/out_nolm" \
  || fail "fallback registration"
grep -q FALLBACK "$work/out_nolm/subject_0001/report.json" || fail "fallback not flagged"
# --texture-landmarks: needs a reference (one line, nothing written); with one (here another subject's transferred
# diffuse) and the outline term the report says how many brow, eye, lip and nose points the texture and shape gave,
# and lists them, and how many shape points the curvature placed (accuracy: scan_test's
# Register.TextureLandmarksFindTheFeaturesASlideMoved, ...RoundsUndo..., ...OutlineTermDraws...). A negative outline
# weight or shape-point count: one line, nothing written.
expect_failure 3 "--texture-reference" "$work/out_tl0" -- reg --scans "$work/s" -o "$work/out_tl0" --texture-landmarks 1
mkdir -p "$work/one" && cp -r "$work/s/subject_0000" "$work/one/"
reg --scans "$work/one" -o "$work/out_tl" --texture-landmarks 1 --texture-reference "$work/r/subject_0001/diffuse.png" \
  --texture-landmark-res 128 --outline-weight 0.3 || fail "texture landmarks"
$py -c "import json,sys; r=json.load(open(sys.argv[1])); t=r['texture_landmarks']; assert t['rounds'] == 1 and 0 <= t['found'][0] <= 43, t; p=t.get('points', []); assert len(p) == (t['found'][0] if t['found'][0] >= 10 else 0) and all(len(q) == 4 and 17 <= q[0] <= 59 for q in p), p; assert r['outline']['distance_to_scan_border_mm']['median'] < 1, r['outline']; s=t['shape_points']; assert len(s['found']) == 1 and s['found'][0] > 0 and s['error_mm']['median'] < 2, s" \
  "$work/out_tl/subject_0000/report.json" || fail "texture landmarks report"
expect_failure 3 "--outline-weight" "$work/out_ow" -- reg --scans "$work/one" -o "$work/out_ow" --outline-weight -1
expect_failure 3 "--shape-points" "$work/out_sp" -- reg --scans "$work/one" -o "$work/out_sp" --shape-points -5
echo "11 passed, 0 failed"
