#!/usr/bin/env bash
# texgen make-dataset through the command line, on a tiny world: four synthetic scans "registered" from their truth
# (template topology, truth maps in the template UV) and a model built from them.
# - the shards: splits by subject (no subject in two splits), every member of the texture-sample layout at its size,
#   masks/ with the synthetic masks, manifests that agree with the tar files (Python's tarfile as the reader);
# - the same seed gives the same bytes: a second run killed with -9 after its first shard and resumed equals the first
#   run byte for byte, and so does a run split over two workers (--shard 0/1 --shards 2);
# - bad input, one line each, exit 3, no shard: a registered folder from another template, a model from another
#   template, a subject without its diffuse map (and --keep-going skipping and listing it), a CelebAMask photo without a face.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 4 --vertices 6000 --res 64 --truth-res 128 -o "$work/s" || fail "synth"
register_truth "$work/t" "$work/s" "$work/r" "*.png"
"$bin" mm-build -q --template "$work/t" --appearance-res 32 --registered "$work/r" -o "$work/m/model.safetensors" \
  || fail "mm-build"
model="$work/m/model.safetensors"
args=(texgen make-dataset -q --threads 2 "$work/r" --model "$model" --render-size 128 --fit-size 128 --input-res 64 --target-res 64
  --hr-res 128 --masks 2 --split 0.5,0.25,0.25 --seed 7)
make() {  # make OUT [flags...]
  local out=$1
  shift
  "$bin" "${args[@]}" -o "$out" "$@"
}

make "$work/a" --write-view-calibration "$work/view.json" || fail "make-dataset"
$py - "$work/a" <<'PY' || fail "shard contents"
import io, json, sys, tarfile
import numpy as np
from skimage import io as skio
root = sys.argv[1]
subjects = {}
for split in ("train", "val", "test"):
    m = json.load(open(f"{root}/{split}/manifest.json"))
    assert m["metadata"]["complete"], split
    n = 0
    for shard in m["shards"]:
        with tarfile.open(f"{root}/{split}/{shard['name']}") as tar:
            samples = {}
            for member in tar.getmembers():
                key, suffix = member.name.split(".", 1)
                samples.setdefault(key, {})[suffix] = tar.extractfile(member).read()
        assert len(samples) == shard["samples"], shard
        for key, s in samples.items():
            meta = json.loads(s["json"])
            assert meta["split"] == split and len(key) == 8
            subjects.setdefault(meta["subject"], set()).add(split)
            sizes = {"unwrap.png": (64, 3), "confidence.png": (64, 1), "mm_albedo.png": (64, 3), "mm_normal.png": (64, 3),
                     "mm_position.png": (64, 3), "diffuse.png": (64, 3), "normal.png": (64, 3), "roughness.png": (64, 1),
                     "specular.png": (64, 1), "diffuse_hr.png": (128, 3), "normal_hr.png": (128, 3),
                     "roughness_hr.png": (128, 1), "specular_hr.png": (128, 1)}
            assert set(sizes) | {"json"} == set(s), sorted(s)
            for name, (size, channels) in sizes.items():
                img = skio.imread(io.BytesIO(s[name]))
                got = img.shape[2] if img.ndim == 3 else 1
                assert img.shape[:2] == (size, size) and got == channels, (name, img.shape)
                bits, colour = s[name][24], s[name][25]  # the PNG header (PIL reads 16-bit RGB as 8-bit)
                assert bits == (16 if name == "mm_position.png" else 8) and colour == (2 if channels == 3 else 0), name
            conf = skio.imread(io.BytesIO(s["confidence.png"]))
            unwrap = skio.imread(io.BytesIO(s["unwrap.png"]))
            assert (unwrap[conf == 0] == 0).all() and (conf > 0).mean() > 0.3, "unwrap only where seen"
            assert [v["name"] for v in meta["views"]] == ["front", "left", "right"]
            assert 0 < meta["unwrap"]["coverage"] <= 1 and meta["unwrap"]["psnr_db_vs_truth"] > 12, meta["unwrap"]
            n += 1
    assert n == m["samples"], (split, n)
assert sorted(subjects) == [f"subject_{i:04d}" for i in range(4)], subjects
assert all(len(v) == 1 for v in subjects.values()), subjects  # no subject in two splits
masks = json.load(open(f"{root}/masks/manifest.json"))
assert masks["samples"] == 8 and masks["metadata"]["complete"], masks
PY

# The per-view calibration (--write-view-calibration, after the complete run): per view the median of (detected − true
# landmarks) / render size over the reports, which carry both; a later run applies it, and refuses other yaws.
$py - "$work/a" "$work/view.json" <<'PY' || fail "view calibration"
import glob, json, sys
import numpy as np
root, path = sys.argv[1:]
c = json.load(open(path))
assert [v["name"] for v in c["views"]] == ["front", "left", "right"], c["views"]
residuals = {}
for p in sorted(glob.glob(f"{root}/reports/*.json")):
    light = json.load(open(p))["lights"][0]
    for v in light["views"]:
        d, t = np.array(v["landmarks_detected_px"]), np.array(v["landmarks_truth_px"])
        assert d.shape == t.shape == (68, 2)
        residuals.setdefault(v["name"], []).append((d - t) / light["sizes"]["render"])
for v in c["views"]:
    assert v["samples"] == 4, v["samples"]
    assert np.allclose(np.array(v["bias"]), np.median(residuals[v["name"]], 0), atol=1e-12), v["name"]
PY
make "$work/vc" --view-calibration "$work/view.json" || fail "make-dataset --view-calibration"
expect_failure 3 "has no left view at yaw 20" "" -- "$bin" "${args[@]}" -o "$work/vc2" --view-calibration \
  "$work/view.json" --yaw-left 20
[ -z "$(find "$work/vc2" -name '*.tar' 2> /dev/null)" ] || fail "vc2: a shard was written"

# Same bytes: killed with -9 once a unit has landed, then resumed; and two workers.
"$bin" "${args[@]}" -o "$work/b" & pid=$!
for _ in $(seq 600); do
  ls "$work"/b/.index/unit-*.json > /dev/null 2>&1 && break
  sleep 0.05
done
kill -9 "$pid" 2> /dev/null
wait "$pid" 2> /dev/null
[ "$(ls "$work"/b/.index | wc -l)" -lt 4 ] || fail "the run finished before it was killed"
make "$work/b" || fail "resume"
make "$work/c" --shard 0 --shards 2 || fail "worker 0"
make "$work/c" --shard 1 --shards 2 || fail "worker 1"
for run in b c; do
  for f in $(cd "$work/a" && ls */*.tar); do cmp -s "$work/a/$f" "$work/$run/$f" || fail "$run/$f differs from the first run"; done
  [ "$(cd "$work/$run" && ls */*.tar | wc -l)" -eq "$(cd "$work/a" && ls */*.tar | wc -l)" ] || fail "$run: shard count"
  for split in train val test masks; do
    cmp -s "$work/a/$split/manifest.json" "$work/$run/$split/manifest.json" || fail "$run/$split/manifest.json differs"
  done
done
[ ! -e "$work/b/.tmp" ] || fail "scratch folder left behind"

no_shard() { [ -z "$(find "$1" -name '*.tar' 2> /dev/null)" ] || fail "$1: a shard was written"; }
# A registered folder from another template (a subject's mesh from a 2000-vertex template).
"$bin" template -q --vertices 2000 -o "$work/t2" || fail "template 2"
cp -r "$work/r" "$work/r_other"
cp "$work/t2/face.obj" "$work/r_other/subject_0000/mesh.obj"
expect_failure 3 "registered to another template" "" -- "$bin" texgen make-dataset "$work/r_other" --model "$model" \
  -o "$work/bad1" --render-size 128 --fit-size 128 --input-res 64 --target-res 64 --hr-res 0
no_shard "$work/bad1"
# A model from another template: built from subjects registered to the 2000-vertex template.
for i in 0 1 2 3; do
  mkdir -p "$work/r2/subject_$i"
  cp "$work"/r/subject_000$i/*.png "$work/r2/subject_$i/"
  $py - "$work/t2/face.obj" "$work/r2/subject_$i/mesh.obj" "$i" <<'PY' || fail "other subjects"
import sys
import numpy as np
rng = np.random.default_rng(int(sys.argv[3]))
out = []
for line in open(sys.argv[1]):
    if line.startswith("v "):
        v = np.array(line.split()[1:4], float) + rng.normal(0, 2, 3)
        line = "v %.6f %.6f %.6f\n" % tuple(v)
    out.append(line)
open(sys.argv[2], "w").writelines(out)
PY
done
"$bin" mm-build -q --template "$work/t2" --appearance-res 32 --registered "$work/r2" -o "$work/m2/model.safetensors" \
  || fail "mm-build 2"
expect_failure 3 "registered to another template" "" -- "$bin" texgen make-dataset "$work/r" \
  --model "$work/m2/model.safetensors" -o "$work/bad2" --render-size 128 --fit-size 128 --input-res 64 --target-res 64 --hr-res 0
no_shard "$work/bad2"
# A subject without its diffuse map: an error naming it, or skipped and listed with --keep-going (other missing maps
# are filled: tests/cli/third_party.sh).
cp -r "$work/r" "$work/r_nomap"
rm "$work/r_nomap/subject_0002/diffuse.png"
expect_failure 3 "subject_0002: has no diffuse map" "" -- "$bin" texgen make-dataset "$work/r_nomap" --model "$model" \
  -o "$work/bad3" --render-size 128 --fit-size 128 --input-res 64 --target-res 64 --hr-res 0
no_shard "$work/bad3"
"$bin" texgen make-dataset --threads 2 "$work/r_nomap" --model "$model" -o "$work/kg" --render-size 256 --input-res 64 \
  --target-res 64 --hr-res 0 --keep-going 2> "$work/kg.err" || fail "keep-going: $(cat "$work/kg.err")"
grep -q "skipped .*subject_0002: has no diffuse map" "$work/kg.err" || fail "keep-going summary: $(cat "$work/kg.err")"
$py - "$work/kg" <<'PY' || fail "keep-going manifests"
import json, sys
m = [json.load(open(f"{sys.argv[1]}/{s}/manifest.json")) for s in ("train", "val", "test")]
assert sum(x["samples"] for x in m) == 3, [x["samples"] for x in m]
assert "subject_0002" in m[0]["metadata"]["skipped"][0]["item"], m[0]["metadata"]["skipped"]
PY
# CelebAMask labels whose photo has no face (flat grey).
mkdir -p "$work/celeba/CelebA-HQ-img" "$work/celeba/CelebAMask-HQ-mask-anno/0"
$py - "$work/celeba" <<'PY' || fail "fake CelebAMask"
import sys
import numpy as np
from skimage import io
d = sys.argv[1]
io.imsave(d + "/CelebA-HQ-img/0.png", np.full((256, 256, 3), 128, np.uint8), check_contrast=False)
skin = np.zeros((128, 128), np.uint8)
skin[30:100, 30:100] = 255
io.imsave(d + "/CelebAMask-HQ-mask-anno/0/00000_skin.png", skin, check_contrast=False)
PY
expect_failure 3 "0.png: no face found" "" -- "$bin" texgen make-dataset "$work/r" --model "$model" -o "$work/bad4" \
  --render-size 128 --fit-size 128 --input-res 64 --target-res 64 --hr-res 0 --split 1,0,0 --celebamask "$work/celeba"
no_shard "$work/bad4"
# CelebAMask-HQ's layout with a real photo (skimage's astronaut) and hand-made part masks: all skin, hair over the top
# half; the fitted face's skin that the hair leaves uncovered becomes a mask sample of its own.
mkdir -p "$work/celeba_ok/CelebA-HQ-img" "$work/celeba_ok/CelebAMask-HQ-mask-anno/0" "$work/r1"
ln -s "$work/r/subject_0000" "$work/r1/subject_0000"
$py - "$work/celeba_ok" <<'PY' || fail "CelebAMask folder"
import shutil, sys
import numpy as np
from skimage import data, io
d = sys.argv[1]
io.imsave(d + "/CelebA-HQ-img/3.png", data.astronaut(), check_contrast=False)
io.imsave(d + "/CelebAMask-HQ-mask-anno/0/00003_skin.png", np.full((512, 512), 255, np.uint8), check_contrast=False)
hair = np.zeros((512, 512), np.uint8)
hair[:120] = 255
io.imsave(d + "/CelebAMask-HQ-mask-anno/0/00003_hair.png", hair, check_contrast=False)
PY
"$bin" texgen make-dataset -q --threads 2 "$work/r1" --model "$model" -o "$work/celeba_run" --render-size 128 \
  --fit-size 128 --input-res 64 --target-res 64 --hr-res 0 --masks 0 --split 1,0,0 --celebamask "$work/celeba_ok" \
  || fail "CelebAMask run"
$py - "$work/celeba_run/masks" <<'PY' || fail "CelebAMask mask"
import io, json, sys, tarfile
import numpy as np
from skimage import io as skio
m = json.load(open(sys.argv[1] + "/manifest.json"))
assert m["samples"] == 1, m
with tarfile.open(sys.argv[1] + "/" + m["shards"][0]["name"]) as tar:
    s = {x.name.split(".", 1)[1]: tar.extractfile(x).read() for x in tar.getmembers()}
meta, mask = json.loads(s["json"]), skio.imread(io.BytesIO(s["mask.png"]))
assert meta["source"] == "celebamask" and meta["photo"] == "3.png", meta
assert mask.shape == (64, 64) and 0 < meta["texels"] == (mask > 0).sum() < 0.9 * 64 * 64, (meta, (mask > 0).sum())
PY
echo "texgen make-dataset: OK"
