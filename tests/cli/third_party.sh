#!/usr/bin/env bash
# Scans as users bring them rather than as `scan synth` writes them, each through the real command line:
# - a quad mesh (an artist's cleaned mesh): triangulated on read with its UV seams, -v says so, it registers as well
#   as the triangle mesh it came from and its maps transfer;
# - a scan with a diffuse map only (photogrammetry), and one with no maps: the geometry registers, the maps it has are
#   transferred, the report says which;
# - run from another folder (/) without BARESKIN_ASSETS: the template finds the assets of the build, scan register
#   finds the template from BARESKIN_TEMPLATE, and with no template anywhere the one error line lists the places searched;
# - a scan remeshed, smoothed and noised beyond what the generator makes still registers to the truth;
# - uvtools bake without --layout: a plain area-correct resize per map type (numpy + oiiotool oracle), said in the log;
# - the diffuse-only quad head through texgen faces and make-dataset: missing maps filled, said once, in the JSON.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 1 --vertices 8000 --res 128 --truth-res 64 -o "$work/s" || fail "synth"
src=$work/s/subject_0000
reg() { "$bin" scan register -q --template "$work/t" --maps-res 64 "$@"; }
population() { mkdir -p "$work/$1" && cp -r "$src" "$work/$1/subject_0000"; }  # population NAME: a copy of the scan
# report.py REPORT MAPS: the registration is as accurate as register.sh asks, and exactly MAPS (comma list) were
# transferred, with their files written and no others.
check_report() {
  $py - "$1" "$2" <<'PY'
import json, os, sys
r = json.load(open(sys.argv[1]))
maps = [m for m in sys.argv[2].split(",") if m]
d = os.path.dirname(sys.argv[1])
assert r["alignment"].startswith("landmarks"), r["alignment"]
assert r["correspondence_error_mm"]["median"] < 2.5, r["correspondence_error_mm"]
assert r["surface_distance_mm"]["median"] < 0.05, r["surface_distance_mm"]
assert r["maps"]["transferred"] == maps, r["maps"]
for m in ("diffuse", "normal", "roughness", "specular"):
    assert os.path.exists(f"{d}/{m}.png") == (m in maps), m
vs = r["maps"].get("vs_truth", {})
if "diffuse" in maps:
    assert vs["diffuse_psnr_db"] > 25, vs
if "normal" in maps:
    assert vs["normal_angle_median_deg"] < 5, vs
assert ("diffuse_psnr_db" in vs) == ("diffuse" in maps) and ("normal_angle_median_deg" in vs) == ("normal" in maps), vs
print(f"ok   {r['scan_triangles']} triangles, correspondence median {r['correspondence_error_mm']['median']:.3f} mm, "
      f"maps {maps or 'none'} {vs}")
PY
}

# 1. Quads: pairs of triangles across an edge whose two corners carry the same UVs on both sides (so no seam is
# crossed) become one quad "f a b d c".
population quads
$py - "$work/quads/subject_0000/mesh.obj" <<'PY' || fail "making the quad mesh"
import sys
path = sys.argv[1]
head, faces = [], []
for line in open(path):
    if line.startswith("f "):
        faces.append([tuple(int(x) for x in c.split("/")[:2]) for c in line.split()[1:]])
    else:
        head.append(line)
edge_face = {}
for i, f in enumerate(faces):
    for k in range(3):
        edge_face.setdefault((f[k], f[(k + 1) % 3]), i)  # directed edge with its (vertex, uv) corners
used, out, quads = [False] * len(faces), [], 0
for i, f in enumerate(faces):
    if used[i]:
        continue
    used[i] = True
    for k in range(3):
        a, b, c = f[k], f[(k + 1) % 3], f[(k + 2) % 3]
        j = edge_face.get((b, a))  # the neighbour across a-b, same UVs at a and b
        if j is not None and not used[j]:
            g = faces[j]
            d = next(x for x in g if x not in (a, b))
            used[j] = True
            out.append([c, a, d, b])
            quads += 1
            break
    else:
        out.append(f)
with open(path, "w") as o:
    o.writelines(head)
    for f in out:
        o.write("f " + " ".join(f"{v}/{t}" for v, t in f) + "\n")
print(f"quad mesh: {quads} quads, {len(out) - quads} triangles (from {len(faces)} triangles)")
assert quads > 0.4 * len(faces)
PY
"$bin" scan register -v --template "$work/t" --maps-res 64 --scans "$work/quads" -o "$work/r_quads" > "$work/log" 2>&1 \
  || fail "quads: $(tail -3 "$work/log")"
grep -q "polygon(s) with more than 3 corners split into triangles" "$work/log" || fail "quads: -v does not say so"
check_report "$work/r_quads/subject_0000/report.json" diffuse,normal,roughness,specular || fail "quads: report"

# 2. A diffuse map only, and no maps at all.
population diffuse_only
rm "$work"/diffuse_only/subject_0000/{normal,roughness,specular}.png
reg --scans "$work/diffuse_only" -o "$work/r_diffuse" || fail "diffuse only"
check_report "$work/r_diffuse/subject_0000/report.json" diffuse || fail "diffuse only: report"
population no_maps
rm "$work"/no_maps/subject_0000/{diffuse,normal,roughness,specular}.png
reg --scans "$work/no_maps" -o "$work/r_none" || fail "no maps"
check_report "$work/r_none/subject_0000/report.json" "" || fail "no maps: report"

# 3. From another folder, without BARESKIN_ASSETS: the build's assets and BARESKIN_TEMPLATE are found, not the CWD.
(cd / && env -u BARESKIN_ASSETS "$bin" template -q --vertices 2000 -o "$work/t_root") || fail "template from /"
[ -f "$work/t_root/face.obj" ] || fail "template from /: no face.obj"
(cd / && env -u BARESKIN_ASSETS BARESKIN_TEMPLATE="$work/t" "$bin" scan register -q --maps-res 0 --scans "$work/no_maps" \
  -o "$work/r_root") || fail "scan register from / with BARESKIN_TEMPLATE"
[ -f "$work/r_root/subject_0000/mesh.ply" ] || fail "scan register from /: no mesh"
cd / || fail "cd /"
expect_failure 4 "the install folder beside the executable" "$work/r_nowhere" -- \
  env -u BARESKIN_TEMPLATE "$bin" scan register -q --scans "$work/no_maps" -o "$work/r_nowhere"
expect_failure 4 "/nowhere/mediapipe_face_mesh: not found in /nowhere (BARESKIN_ASSETS)" "$work/t_nowhere" -- \
  env BARESKIN_ASSETS=/nowhere "$bin" template -q -o "$work/t_nowhere"
cd "$work" || fail "cd back"

# 4. Beyond the generator: the scan remeshed (every triangle split in four at its edge midpoints, UVs with it), smoothed
# (two Laplacian passes) and noised (0.2 mm, seeded), so its vertices, triangles and surface are none that `scan
# synth` made. It still registers to the truth within register.sh's bounds.
population rough
$py - "$work/rough/subject_0000/mesh.obj" <<'PY' || fail "making the rough scan"
import sys
import numpy as np
path = sys.argv[1]
V, T, F = [], [], []
for line in open(path):
    t = line.split()
    if t[:1] == ["v"]:
        V.append([float(x) for x in t[1:4]])
    elif t[:1] == ["vt"]:
        T.append([float(x) for x in t[1:3]])
    elif t[:1] == ["f"]:
        F.append([[int(x) - 1 for x in c.split("/")[:2]] for c in t[1:4]])
V, T = list(map(list, V)), list(map(list, T))
vmid, tmid = {}, {}
def mid(table, store, a, b):
    key = (min(a, b), max(a, b))
    if key not in table:
        table[key] = len(store)
        store.append([(x + y) / 2 for x, y in zip(store[a], store[b])])
    return table[key]
out = []
for (a, ta), (b, tb), (c, tc) in F:
    ab, bc, ca = mid(vmid, V, a, b), mid(vmid, V, b, c), mid(vmid, V, c, a)
    tab, tbc, tca = mid(tmid, T, ta, tb), mid(tmid, T, tb, tc), mid(tmid, T, tc, ta)
    out += [[(a, ta), (ab, tab), (ca, tca)], [(ab, tab), (b, tb), (bc, tbc)], [(ca, tca), (bc, tbc), (c, tc)],
            [(ab, tab), (bc, tbc), (ca, tca)]]
V = np.array(V)
nbr = [set() for _ in V]
for f in out:
    for i in range(3):
        nbr[f[i][0]].update((f[(i + 1) % 3][0], f[(i + 2) % 3][0]))
for _ in range(2):
    V = 0.5 * V + 0.5 * np.array([V[list(n)].mean(0) for n in nbr])
V += np.random.default_rng(5).normal(0, 0.2, V.shape)
with open(path, "w") as o:
    o.writelines(f"v {x:.6f} {y:.6f} {z:.6f}\n" for x, y, z in V)
    o.writelines(f"vt {u:.9f} {v:.9f}\n" for u, v in T)
    o.writelines("f " + " ".join(f"{v + 1}/{t + 1}" for v, t in f) + "\n" for f in out)
print(f"rough scan: {len(V)} vertices, {len(out)} triangles (from {len(F)})")
PY
reg --scans "$work/rough" -o "$work/r_rough" || fail "rough scan"
$py - "$work/r_rough/subject_0000/report.json" <<'PY' || fail "rough scan: accuracy"
import json, sys
r = json.load(open(sys.argv[1]))
c, s = r["correspondence_error_mm"], r["surface_distance_mm"]
assert c["median"] < 2.5 and s["median"] < 0.3, (c, s)
assert r["maps"]["vs_truth"]["normal_angle_median_deg"] < 10, r["maps"]
print(f"ok   remeshed + smoothed + noised scan ({r['scan_triangles']} triangles): correspondence median {c['median']:.3f} "
      f"mm, p95 {c['p95']:.3f} mm; surface distance median {s['median']:.3f} mm; maps {r['maps']['vs_truth']}")
PY

# 5. uvtools bake without --layout: every texel counts (a plain box filter per map type), no seam handling.
"$bin" uvtools bake "$src" -o "$work/baked" --sizes 64,32 --format png > "$work/log" 2>&1 || fail "bake: $(cat "$work/log")"
grep -q "no --layout: a plain area-correct resize per map type" "$work/log" || fail "bake: the log does not say so"
grep -q '"layout": "none' "$work/baked/bake.json" || fail "bake.json does not say there was no layout"
$py "$here/../python/bake_oracle.py" - "$src" "$work/baked" 64 32 || fail "bake without a layout: oracle"
# 6. Diffuse-only scans all the way: the quad head with its diffuse map only is registered, then `texgen faces` and
# `texgen make-dataset` take it beside a subject with all four maps. Each warns once, naming it; its samples' JSON lists
# the filled maps; faces fill roughness and specular with the other subject's maps, make-dataset's targets are flat
# normals and the constants 0.55 / 0.30 inside the layout. The model comes from three synthetic subjects.
mkdir -p "$work/qd" && cp -r "$work/quads/subject_0000" "$work/qd/" || fail "quad head copy"
rm "$work"/qd/subject_0000/{normal,roughness,specular}.png
reg --scans "$work/qd" -o "$work/r_qd" || fail "diffuse-only quad head"
check_report "$work/r_qd/subject_0000/report.json" diffuse || fail "diffuse-only quad head: report"
mkdir -p "$work/world"
cp -r "$work/r_qd/subject_0000" "$work/world/subject_0000" && cp -r "$work/r_quads/subject_0000" "$work/world/subject_0001" \
  || fail "world"
"$bin" scan synth -q --template "$work/t" --count 3 --vertices 6000 --res 64 --truth-res 64 -o "$work/s3" || fail "synth 3"
register_truth "$work/t" "$work/s3" "$work/r3" diffuse.png
"$bin" mm-build -q --template "$work/t" --appearance-res 32 --registered "$work/r3" -o "$work/m/model.safetensors" \
  || fail "mm-build"
# one_warning LOG: exactly one warning, naming subject_0000 and not subject_0001.
one_warning() {
  [ "$(grep -c "warn" "$1")" -eq 1 ] && grep "warn" "$1" | grep -q "subject_0000 (" && ! grep -q "subject_0001" "$1" \
    || fail "not one warning naming subject_0000 alone: $(cat "$1")"
}
"$bin" texgen faces -q --threads 2 --registered "$work/world" --model "$work/m/model.safetensors" --mm-subjects 2 \
  --val 1 --test 1 --seed 3 --align truth --map-size 64 --layer-size 32 --backgrounds "" --count 12 --shard-size 4 \
  -o "$work/faces" 2> "$work/faces.err" || fail "texgen faces with a diffuse-only subject: $(cat "$work/faces.err")"
one_warning "$work/faces.err"
$py - "$work/faces" <<'PY' || fail "texgen faces: filled_maps"
import glob, json, sys, tarfile
seen = {}
for path in glob.glob(f"{sys.argv[1]}/*/*.tar"):
    with tarfile.open(path) as tar:
        for m in tar.getmembers():
            if m.name.endswith(".json"):
                meta = json.loads(tar.extractfile(m).read())
                truth = meta["subject_truth"]
                seen.setdefault(meta["subject"], []).append(truth.get("filled_maps"))
                if meta["subject"] == "scan/subject_0000":
                    assert "filled" in truth["maps"], truth["maps"]
assert seen.get("scan/subject_0000") and all(f == ["roughness", "specular"] for f in seen["scan/subject_0000"]), seen
assert all(f is None for s, fs in seen.items() if s != "scan/subject_0000" for f in fs), seen
print(f"ok   texgen faces: {len(seen['scan/subject_0000'])} sample(s) of the diffuse-only head record filled_maps")
PY
"$bin" texgen make-dataset -q --threads 2 "$work/world" --model "$work/m/model.safetensors" --render-size 128 \
  --fit-size 128 --input-res 64 --target-res 64 --hr-res 0 --masks 0 --split 0.5,0.5,0 -o "$work/ds" 2> "$work/ds.err"
ds=$?
if [ $ds -ne 0 ] && grep -q "which this build lacks (no Torch side)" "$work/ds.err"; then
  echo "skip texgen make-dataset: this build has no face detector (Torch side)"
else
  [ $ds -eq 0 ] || fail "make-dataset with a diffuse-only subject: $(cat "$work/ds.err")"
  one_warning "$work/ds.err"
  $py - "$work/ds" <<'PY' || fail "make-dataset: filled maps"
import glob, io, json, sys, tarfile
import numpy as np
from skimage import io as skio
seen = {}
for path in glob.glob(f"{sys.argv[1]}/*/texture-*.tar"):
    with tarfile.open(path) as tar:
        groups = {}
        for m in tar.getmembers():
            key, suffix = m.name.split(".", 1)
            groups.setdefault(key, {})[suffix] = tar.extractfile(m).read()
    for g in groups.values():
        meta = json.loads(g["json"])
        seen[meta["subject"]] = meta.get("filled_maps")
        n, r, s = (skio.imread(io.BytesIO(g[k + ".png"])) for k in ("normal", "roughness", "specular"))
        if meta["subject"] == "subject_0000":
            flat = np.unique(n.reshape(-1, 3), axis=0)  # (0.5, 0.5, 1) everywhere, 8-bit
            assert len(flat) == 1 and abs(flat[0] - [127.5, 127.5, 255]).max() <= 1, flat
            inside = r > 0
            assert 0.3 < inside.mean() < 1 and (inside == (s > 0)).all(), inside.mean()
            vr, vs = np.unique(r[inside]), np.unique(s[inside])  # 0.55 and 0.30, 8-bit
            assert len(vr) == 1 and abs(vr[0] - 0.55 * 255) <= 1 and len(vs) == 1 and abs(vs[0] - 0.3 * 255) <= 1, (vr, vs)
        else:
            assert len(np.unique(r)) > 2, "the full subject's roughness looks filled"
assert seen == {"subject_0000": ["normal", "roughness", "specular"], "subject_0001": None}, seen
print("ok   make-dataset: the diffuse-only head's targets are filled and its JSON says so")
PY
fi
echo "third-party scans: all cases passed"
