#!/usr/bin/env bash
# Texture inference learns, scored on subjects it never saw: a tiny texture world (synthetic scans registered from
# their truth, a model built from four other scans, `texgen make-dataset`), split by subject, the held-out subjects
# as the validation split.
# - the UV net (`train texture --arch uv`) beats the 3DMM-only maps (the 3DMM albedo, the truth's own mean roughness
#   and specular) and its own start (the unwrap over the 3DMM albedo) on the held-out subjects; on the normal map,
#   whose truth is flat in this world, it stays within 3 dB of the flat normal (both above 50 dB);
# - SRGAN ×4 (`train upscale`, pixel-loss phase) beats bicubic on the held-out subjects' true diffuse maps;
# - `bareskin run` on a held-out subject's bare-skin face image from `texgen faces` writes a complete avatar folder
#   whose GLB the independent reader (tests/python/glb_oracle.py) accepts and whose diffuse map is closer to the
#   subject's true diffuse than the 3DMM's mean albedo is; with `--face-mask` hiding the whole face nothing is
#   unwrapped, and a mask of another size is refused (exit 3, nothing written);
# - `texgen run-dataset` pairs those faces, through the run pipeline, with their subjects' true maps.
# A broken loss or a detached gradient leaves the UV net at its start (grey roughness and specular) and SRGAN at
# bicubic, which fails here.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 8 --vertices 6000 --res 128 --truth-res 256 --seed 4 -o "$work/s" \
  || fail "synth"
"$bin" scan synth -q --template "$work/t" --count 4 --vertices 6000 --res 128 --truth-res 256 --seed 9 -o "$work/sm" \
  || fail "synth (model subjects)"
register_truth "$work/t" "$work/s" "$work/r" "*.png"
register_truth "$work/t" "$work/sm" "$work/rm" diffuse.png
model="$work/m/model.safetensors"
"$bin" mm-build -q --template "$work/t" --appearance-res 64 --registered "$work/rm" -o "$model" || fail "mm-build"
"$bin" texgen make-dataset -q --threads 2 "$work/r" --model "$model" --render-size 256 --fit-size 128 --input-res 64 \
  --target-res 64 --hr-res 256 --masks 2 --split 0.75,0.25,0 --seed 2 -o "$work/d" || fail "make-dataset"

# The UV net at 64², width 8, L1 on the layout, validated on the held-out subjects.
steps=${TEXTURE_LEARNING_STEPS:-300}
"$bin" -q --threads 2 train texture --arch uv --res 64 --generator '{"ngf": 8, "num_downs": 5}' \
  --data "$work/d/train" --val "$work/d/val" --masks "$work/d/masks" --model "$model" -o "$work/tex" \
  --steps "$steps" --batch 4 --lambda-gan 0 --lambda-feat 0 --lambda-perceptual 0 --lambda-l1 10 --lr 2e-3 \
  --eval-every "$steps" --sample-every 0 --checkpoint-every 1000 || fail "train texture"
"$py" - "$work/tex/eval.csv" <<'PY' || fail "the UV net did not learn: $(tail -9 "$work/tex/eval.csv")"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
last = max(int(r["step"]) for r in rows)
v = {r["name"]: float(r["value"]) for r in rows if int(r["step"]) == last}
for m in ("diffuse", "normal", "roughness", "specular"):
    print(f"{m}: UV net {v['psnr_' + m]:.2f} dB, 3DMM-only {v['psnr_mm_' + m]:.2f} dB")
print(f"diffuse: the UV net's start (unwrap over the 3DMM albedo) {v['psnr_unwrap_diffuse']:.2f} dB")
assert v["psnr_diffuse"] > max(v["psnr_mm_diffuse"], v["psnr_unwrap_diffuse"]) + 0.05, "diffuse"
for m in ("roughness", "specular"):
    assert v["psnr_" + m] > v["psnr_mm_" + m] + 0.3, m
assert v["psnr_normal"] > v["psnr_mm_normal"] - 3, "normal"  # above 50 dB the difference is noise of 0.3 %
PY

# SRGAN x4 on the diffuse: 256² crops of the 256² true maps, validated on the held-out subjects' whole maps.
"$bin" -q --threads 2 train upscale --map diffuse --phase l1 --data "$work/d/train" --val "$work/d/val" \
  --model "$model" -o "$work/up" --patch 128 --steps ${TEXTURE_LEARNING_SR_STEPS:-150} --batch 2 \
  --generator '{"num_feat": 16, "num_block": 2}' --lr 2e-3 --eval-every ${TEXTURE_LEARNING_SR_STEPS:-150} \
  --sample-every 0 --checkpoint-every 1000 || fail "train upscale"
"$py" - "$work/up/eval.csv" <<'PY' || fail "SRGAN did not beat bicubic: $(tail -3 "$work/up/eval.csv")"
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
last = max(int(r["step"]) for r in rows)
v = {r["name"]: float(r["value"]) for r in rows if int(r["step"]) == last}
print(f"x4 diffuse: SRGAN {v['psnr_srgan']:.2f} dB, bicubic {v['psnr_bicubic']:.2f} dB")
assert v["psnr_srgan"] > v["psnr_bicubic"] + 0.1, v
PY

# bareskin run on a face of a held-out subject (texgen faces): its bare skin over the photo's background and hair
# (what a perfect G hands over; a G trained in seconds would not be one) through `run --no-bareskin`: a complete avatar folder, its GLB read by the
# independent reader, its diffuse closer to the truth than the 3DMM mean albedo.
mkdir -p "$work/rv"
for s in $("$py" -c "import json,sys; print(' '.join(json.load(open(sys.argv[1]))['metadata']['subjects']))" \
  "$work/d/val/manifest.json"); do ln -s "$work/r/$s" "$work/rv/$s"; done
"$bin" -q --threads 2 texgen faces --registered "$work/rv" --model "$model" --mm-subjects 0 --count 2 --val 0 --test 0 \
  --styles none --align truth --map-size 64 --layer-size 32 --backgrounds "" --occluders 0 --seed 3 -o "$work/f" \
  || fail "texgen faces"
"$py" - "$work/f/train" "$work/face.png" <<'PY' || fail "could not read the face sample"
import json, os, sys, tarfile
split, png = sys.argv[1:]
m = json.load(open(os.path.join(split, "manifest.json")))
with tarfile.open(os.path.join(split, m["shards"][0]["name"])) as tar:
    first = {}
    for member in tar:
        key, _, suffix = member.name.partition(".")
        first.setdefault("key", key)
        if key == first["key"]:
            first[suffix] = tar.extractfile(member).read()
import io
import numpy as np
from skimage import io as skio
bare, made = (skio.imread(io.BytesIO(first[k]))[..., :3] for k in ("bare.png", "makeup.png"))
skio.imsave(png, np.where(bare.max(-1, keepdims=True) > 0, bare, made), check_contrast=False)  # G keeps the rest
meta = json.loads(first["json"])
json.dump({"scheme": "ibug68", "units": "px", "points": meta["landmarks"]}, open(png[:-4] + "_lm.json", "w"))
open(png[:-4] + "_subject.txt", "w").write(meta["subject"].split("/")[-1])
PY
# texgen run-dataset: the held-out faces through the run pipeline (mm-fit, no G), paired with their subjects' true
# maps as stored; faces of subjects the texture split lacks are refused with exit 3 and nothing written.
"$bin" -q --threads 2 texgen run-dataset --faces "$work/f/train" --textures "$work/d/val" --model "$model" \
  --input-res 64 -o "$work/rd" || fail "texgen run-dataset"
"$py" - "$work/rd" "$work/d/val" <<'PY' || fail "run-dataset's samples are wrong"
import io, json, os, sys, tarfile
import numpy as np
from skimage import io as skio
def samples(split):
    m = json.load(open(os.path.join(split, "manifest.json")))
    out = {}
    for s in m["shards"]:
        with tarfile.open(os.path.join(split, s["name"])) as tar:
            for member in tar:
                key, _, suffix = member.name.partition(".")
                out.setdefault(key, {})[suffix] = tar.extractfile(member).read()
    return m, out
m, rd = samples(sys.argv[1])
truth = {}
for s in samples(sys.argv[2])[1].values():
    truth.setdefault(json.loads(s["json"])["subject"], s)
assert m["metadata"]["samples"] == len(rd) == 2, (m["metadata"], len(rd))
for s in rd.values():
    meta = json.loads(s["json"])
    for k in ("diffuse.png", "normal.png", "roughness.png", "specular.png"):
        assert s[k] == truth[meta["subject"]][k], k
    unwrap = skio.imread(io.BytesIO(s["unwrap.png"]))
    seen = skio.imread(io.BytesIO(s["confidence.png"])) > 0
    assert unwrap.shape[:2] == (64, 64) and seen.mean() > 0.2 and unwrap[seen].max() > 0, seen.mean()
    assert meta["coefficients_from"] == "mm-fit" and not meta["bareskin"], meta
PY
"$bin" -q texgen run-dataset --faces "$work/f/train" --textures "$work/d/train" --model "$model" --input-res 64 \
  -o "$work/rd_bad" 2> "$work/rd_bad.err"
rc=$?
[ $rc -eq 3 ] && [ ! -e "$work/rd_bad" ] && grep -q "true maps\|no face of a subject" "$work/rd_bad.err" ||
  fail "run-dataset on faces of other subjects: exit $rc, $(cat "$work/rd_bad.err")"

# Faces made without face.png: one line that says what to do (--no-face-masks), exit 3, nothing written.
"$py" - "$work/f/train" "$work/f_nomask" <<'PY' || fail "could not write the faces without face.png"
import json, os, sys, tarfile, zlib
src, dst = sys.argv[1:]
os.makedirs(dst)
m = json.load(open(os.path.join(src, "manifest.json")))
for s in m["shards"]:
    with tarfile.open(os.path.join(src, s["name"])) as t, tarfile.open(os.path.join(dst, s["name"]), "w") as o:
        for member in t:
            if not member.name.endswith(".face.png"):
                o.addfile(member, t.extractfile(member))
    data = open(os.path.join(dst, s["name"]), "rb").read()
    s["crc32"], s["bytes"] = zlib.crc32(data), len(data)
json.dump(m, open(os.path.join(dst, "manifest.json"), "w"))
PY
"$bin" -q texgen run-dataset --faces "$work/f_nomask" --textures "$work/d/val" --model "$model" --input-res 64 \
  -o "$work/rd_nomask" 2> "$work/rd_nomask.err"
rc=$?
[ $rc -eq 3 ] && [ ! -e "$work/rd_nomask" ] && grep -q "no face.png.*--no-face-masks" "$work/rd_nomask.err" ||
  fail "run-dataset on faces without face.png: exit $rc, $(cat "$work/rd_nomask.err")"

"$bin" -q --threads 2 run "$work/face.png" --landmarks "$work/face_lm.json" --model "$model" --texture "$work/tex" \
  --upscale "$work/up" --no-bareskin --preview-size 64 -o "$work/avatar" || fail "run"
for f in avatar.glb mesh.obj coefficients.json maps/diffuse.png maps/normal.png maps/roughness.png maps/specular.png \
  light_sh.json light_env.exr report.json; do
  [ -s "$work/avatar/$f" ] || fail "run wrote no $f"
done
"$py" "$here/../python/glb_oracle.py" "$work/avatar/avatar.glb" > /dev/null || fail "the GLB does not pass the reader"
"$py" - "$work/avatar/maps/diffuse.png" "$work/r/$(cat "$work/face_subject.txt")/diffuse.png" "$model" \
  "$here/../python" <<'PY' || fail "the avatar's diffuse is not closer to the truth than the 3DMM mean albedo"
import sys
import numpy as np
from skimage import io, transform
sys.path.insert(0, sys.argv[4])
from safetensors_oracle import read_safetensors
out = io.imread(sys.argv[1])[..., :3] / 255.0
truth = transform.resize(io.imread(sys.argv[2])[..., :3] / 255.0, out.shape, order=1, anti_aliasing=True)
m = read_safetensors(sys.argv[3])[1]
lin = m["appearance_mean"].astype(np.float64).clip(0, 1)  # linear RGB, row 0 = v 1, as the maps
srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
mean = transform.resize(srgb, out.shape, order=1)
layout = transform.resize(m["appearance_mask"].astype(float), out.shape[:2], order=0) > 0.5
psnr = lambda a: -10 * np.log10(((a - truth)[layout] ** 2).mean())
print(f"run's diffuse vs the truth: {psnr(out):.2f} dB; the 3DMM mean albedo: {psnr(mean):.2f} dB")
assert psnr(out) > psnr(mean) + 1, (psnr(out), psnr(mean))
PY
# --face-mask: a mask that hides the whole face leaves every texel unseen (the net fills the whole layout); a mask
# of another size than the photo's is refused with exit 3 and nothing written.
"$py" - "$work/face.png" "$work/black.png" "$work/small.png" <<'PY' || fail "could not write the masks"
import sys
import numpy as np
from skimage import io
h, w = io.imread(sys.argv[1]).shape[:2]
io.imsave(sys.argv[2], np.zeros((h, w), np.uint8), check_contrast=False)
io.imsave(sys.argv[3], np.full((h // 2, w), 255, np.uint8), check_contrast=False)
PY
"$bin" -q --threads 2 run "$work/face.png" --landmarks "$work/face_lm.json" --model "$model" --texture "$work/tex" \
  --no-upscale --no-bareskin --preview-size 64 --face-mask "$work/black.png" -o "$work/masked" || fail "run --face-mask"
"$py" - "$work/avatar/unwrap.png" "$work/masked/unwrap.png" <<'PY' || fail "the face mask did not empty the unwrap"
import sys
from skimage import io
seen, masked = (io.imread(f)[..., :3].max() for f in sys.argv[1:3])
assert seen > 0 and masked == 0, (seen, masked)
PY
"$bin" -q run "$work/face.png" --landmarks "$work/face_lm.json" --model "$model" --texture "$work/tex" --no-upscale \
  --no-bareskin --face-mask "$work/small.png" -o "$work/bad_mask" 2> "$work/bad_mask.err"
rc=$?
[ $rc -eq 3 ] && [ ! -e "$work/bad_mask" ] && grep -q "small.png" "$work/bad_mask.err" ||
  fail "a face mask of the wrong size: exit $rc, $(cat "$work/bad_mask.err")"
echo "texture learning: ok"
