#!/usr/bin/env bash
# mm-build / mm-eval through the command line. "Registered" subjects are made from `scan synth` truth (perfect
# registrations + truth maps in the template UV); the numpy oracle (tests/python/mm_oracle.py) checks GPA, the PCA
# against numpy's SVD, the appearance mean and the metrics; mm-fit recovers known coefficients, also from landmarks
# with 1.5 px noise. Then bad input: a different vertex count, a different triangle list, a NaN vertex, too few
# subjects, identical subjects, too many components asked: each one line naming the problem, exit 3, no model written.
# Subjects without a diffuse map are left out of the appearance model and named. Last, mm-build from scans is killed
# with -9 while it registers and rerun: the model is identical to an uninterrupted build.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 8 --vertices 8000 --res 64 --truth-res 64 -o "$work/s" || fail "synth"
register_truth "$work/t" "$work/s" "$work/r"
build() { "$bin" mm-build -q --template "$work/t" --appearance-res 32 "$@"; }

build --registered "$work/r" -o "$work/m/model.safetensors" --export-obj "$work/m/obj" || fail "mm-build"
for f in model.safetensors model.build.json model.config.json obj/mean.obj obj/shape1_plus3sd.obj obj/appearance_mean.png; do
  [ -f "$work/m/$f" ] || fail "missing $f"
done
"$bin" mm-eval -q "$work/m/model.safetensors" "$work/r" || fail "mm-eval"
for f in metrics.csv metrics.json compactness.svg generalization.svg specificity.svg generalization_regions.svg; do
  [ -f "$work/m/model_metrics/$f" ] || fail "missing metrics/$f"
done
$py "$here/../python/mm_oracle.py" "$work/m/model.safetensors" "$work/r" "$work/m/model_metrics/metrics.csv" "$work/m/obj" \
  || fail "oracle"

# uvtools through the model: a render of the model at some coefficients, unwarped through the same coefficients,
# gives back the model's appearance where seen.
echo '{"alpha": [], "rotation": [0, 0, 0], "translation": [0, 0, 0]}' > "$work/zero.json"
"$bin" render -q --model "$work/m/model.safetensors" --coeffs "$work/zero.json" --camera pinhole --passes albedo \
  --size 256 -o "$work/mean.png" || fail "render mean"
"$bin" uvtools unwarp -q "$work/mean.png" --model "$work/m/model.safetensors" --coeffs "$work/zero.json" --size 32 \
  -o "$work/uv_model.exr" || fail "unwarp model"
$py - "$here/../python" "$work" <<'PY' || fail "unwarp via the model"
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import read
from safetensors_oracle import read_safetensors
w = sys.argv[2]
_, m = read_safetensors(w + "/m/model.safetensors")
u, c = read(w + "/uv_model.exr")[..., :3], read(w + "/uv_model_confidence.exr")[..., 0]
seen = c > 0.5
assert seen.sum() > 0.3 * m["appearance_mask"].sum(), seen.sum()
err = np.abs(u - m["appearance_mean"])[seen].mean()
assert err < 0.02, err
print(f"ok   unwarp via the model: mean |difference| to the appearance mean {err:.4f} over {seen.sum()} texels")
PY
"$bin" uvtools mask -q --model "$work/m/model.safetensors" --coeffs "$work/zero.json" --synthetic hand --size 64 \
  --image-size 128 -o "$work/mask_model.png" || fail "mask via model"
echo '{"alpha": [2, -1], "beta": [1], "delta": [1], "rotation": [0, 0.3, 0]}' > "$work/fit.json"
"$bin" render -q --model "$work/m/model.safetensors" --coeffs "$work/fit.json" --camera pinhole --passes colour,mask \
  --size 64 -o "$work/model_{pass}.png" || fail "render model"
oiiotool --stats "$work/model_mask.png" | grep -q "Stats Max: 255 (of 255)" || fail "render model: empty mask"
expect_failure 3 "give a mesh or --model, not both" "$work/x.png" -- \
  "$bin" render -q "$work/m/obj/mean.obj" --model "$work/m/model.safetensors" --coeffs "$work/fit.json" -o "$work/x.png"
# mm-fit: landmarks of a render at known coefficients give the coefficients back.
echo '{"alpha": [1.2, -0.8, 0.5], "delta": [0.8], "rotation": [0.05, 0.25, -0.03], "translation": [5, -8, 20]}' \
  > "$work/truth.json"
"$bin" render -q --model "$work/m/model.safetensors" --coeffs "$work/truth.json" --camera pinhole --passes colour \
  --size 256 --landmarks-out "$work/lm.json" -o "$work/truth.png" || fail "render for the fit"
"$bin" mm-fit -q "$work/truth.png" --model "$work/m/model.safetensors" --landmarks "$work/lm.json" \
  -o "$work/fitted.json" --trace "$work/trace.csv" || fail "mm-fit"
$py - "$work/truth.json" "$work/fitted.json" "$work/trace.csv" <<'PY' || fail "mm-fit accuracy"
import csv, json, sys
t, f = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
# The trace starts at iteration 0, its clock runs forward, and it ends at the values the fit reports.
rows = list(csv.DictReader(open(sys.argv[3])))
for stage, final in (("landmarks", f["landmark_rms_px"]), ("photometric", f["photometric_psnr_db"])):
    r = [x for x in rows if x["stage"] == stage]
    assert r[0]["iteration"] == "0" and len(r) >= 2, stage
    ms = [float(x["milliseconds"]) for x in r]
    assert ms == sorted(ms), (stage, ms)
    assert abs(float(r[-1]["value"]) - final) < 1e-3 * max(1, abs(final)), (stage, r[-1], final)
assert float([x for x in rows if x["stage"] == "landmarks"][0]["value"]) > 5 * f["landmark_rms_px"]
assert f["landmark_rms_px"] < 1, f["landmark_rms_px"]
assert max(abs(a - b) for a, b in zip(t["rotation"], f["rotation"])) < 0.01, f["rotation"]
assert max(abs(a - b) for a, b in zip(t["translation"], f["translation"])) < 2, f["translation"]
assert max(abs(a - b) for a, b in zip(t["alpha"] + [0] * 9, f["alpha"])) < 0.2, f["alpha"]
assert abs(f["delta"][0] - 0.8) < 0.2 and f["photometric_psnr_db"] > 30, (f["delta"], f["photometric_psnr_db"])
print(f"ok   mm-fit: landmark RMS {f['landmark_rms_px']:.3f} px, photometric PSNR {f['photometric_psnr_db']:.1f} dB, "
      f"delta {f['delta'][0]:.3f} (true 0.8)")
PY
# The same with detector-like landmark noise (Gaussian, 1.5 px per coordinate, seeded): the pose and identity are
# still recovered, and the residual stays at the noise level (no overfitting of the noise, no failure to converge).
$py - "$work/lm.json" "$work/lm_noisy.json" <<'PY' || fail "noisy landmarks"
import json, sys
import numpy as np
lm = json.load(open(sys.argv[1]))
p = np.array(lm["points"]) + np.random.default_rng(3).normal(0, 1.5, (68, 2))
lm["points"] = p.tolist()
json.dump(lm, open(sys.argv[2], "w"))
PY
"$bin" mm-fit -q "$work/truth.png" --model "$work/m/model.safetensors" --landmarks "$work/lm_noisy.json" --no-photometric \
  -o "$work/fitted_noisy.json" || fail "mm-fit on noisy landmarks"
"$bin" render -q --model "$work/m/model.safetensors" --coeffs "$work/fitted_noisy.json" --camera pinhole --passes mask \
  --size 256 --landmarks-out "$work/lm_refit.json" -o "$work/refit.png" || fail "render the noisy fit"
$py - "$work/truth.json" "$work/fitted_noisy.json" "$work/lm.json" "$work/lm_noisy.json" "$work/lm_refit.json" <<'PY' \
  || fail "mm-fit accuracy on noisy landmarks"
import json, sys
import numpy as np
t, f = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
clean, noisy, fit = (np.array(json.load(open(p))["points"]) for p in sys.argv[3:6])
rms = lambda a, b: float(np.sqrt(((a - b) ** 2).sum(1).mean()))
noise, to_clean = rms(noisy, clean), rms(fit, clean)
rot = max(abs(a - b) for a, b in zip(t["rotation"], f["rotation"]))
# The residual stays at the noise level (1.5 px per coordinate: 2.1 px per point), the fitted face's landmarks lie
# closer to the true ones than the noisy input does (the model constrains the shape), and the pose holds.
assert abs(f["landmark_rms_px"] - rms(fit, noisy)) < 0.05, (f["landmark_rms_px"], rms(fit, noisy))
assert 0.6 * noise < f["landmark_rms_px"] < 1.1 * noise, (f["landmark_rms_px"], noise)
assert to_clean < 0.6 * noise and rot < 0.03, (to_clean, noise, rot)
print(f"ok   mm-fit, landmarks + 1.5 px noise ({noise:.2f} px RMS): residual {f['landmark_rms_px']:.2f} px, fitted "
      f"landmarks {to_clean:.2f} px from the true ones, rotation off {rot:.4f} rad")
PY
expect_failure 3 "68 2D landmarks" "$work/bad_fit.json" -- "$bin" mm-fit -q "$work/truth.png" \
  --model "$work/m/model.safetensors" --landmarks "$work/t/landmarks.json" -o "$work/bad_fit.json"
grep -q '<polyline' "$work/trace_landmarks.svg" && grep -q '<polyline' "$work/trace_photometric.svg" || fail "mm-fit trace charts"
# --skin-mask: a glove painted over a cheek pulls δ and γ when every face pixel counts; with the glove masked out the
# fit recovers δ as on the clean render. A mask of another size is refused.
$py - "$work" <<'PY' || fail "occluded render"
import sys
import numpy as np, skimage.io as io
w = sys.argv[1]
img = io.imread(f"{w}/truth.png")
yy, xx = np.mgrid[0:img.shape[0], 0:img.shape[1]]
glove = ((xx - 95) / 38.0) ** 2 + ((yy - 150) / 55.0) ** 2 < 1
img[glove, :3] = [200, 170, 90]
io.imsave(f"{w}/occluded.png", img, check_contrast=False)
io.imsave(f"{w}/skin.png", np.where(glove, 0, 255).astype(np.uint8), check_contrast=False)
io.imsave(f"{w}/skin_small.png", np.full((64, 64), 255, np.uint8), check_contrast=False)
PY
for m in none skin; do
  extra=()
  [ $m = skin ] && extra=(--skin-mask "$work/skin.png")
  "$bin" mm-fit -q "$work/occluded.png" --model "$work/m/model.safetensors" --landmarks "$work/lm.json" \
    -o "$work/occluded_$m.json" "${extra[@]}" || fail "mm-fit occluded ($m)"
done
$py - "$work/occluded_none.json" "$work/occluded_skin.json" <<'PY' || fail "mm-fit --skin-mask"
import json, sys
none, skin = (json.load(open(p)) for p in sys.argv[1:3])
assert abs(skin["delta"][0] - 0.8) < 0.2 and skin["photometric_psnr_db"] > 30, (skin["delta"], skin["photometric_psnr_db"])
assert skin["photometric_pixels"] < none["photometric_pixels"]
assert abs(none["delta"][0] - 0.8) > 2 * abs(skin["delta"][0] - 0.8), (none["delta"][0], skin["delta"][0])
print(f"ok   mm-fit --skin-mask: delta {skin['delta'][0]:.3f} with the glove masked, {none['delta'][0]:.3f} without (true 0.8)")
PY
expect_failure 3 "skin_small.png: is 64x64" "$work/bad_mask.json" -- "$bin" mm-fit -q "$work/occluded.png" \
  --model "$work/m/model.safetensors" --landmarks "$work/lm.json" --skin-mask "$work/skin_small.png" -o "$work/bad_mask.json"
echo '{"points": [[1, 2]]}' > "$work/notc.json"  # a landmark file; {} (the mean face) is fine, as the demo uses it
expect_failure 3 "notc.json: holds no coefficients" "$work/x.exr" -- \
  "$bin" uvtools unwarp -q "$work/mean.png" --model "$work/m/model.safetensors" --coeffs "$work/notc.json" -o "$work/x.exr"
echo '{}' > "$work/mean_face.json"
"$bin" render -q --model "$work/m/model.safetensors" --coeffs "$work/mean_face.json" --size 32 -o "$work/mean_face.png" \
  || fail "render at {}"
echo '{"alpha": [1, "x"]}' > "$work/badc.json"
expect_failure 3 "alpha holds a value" "$work/x.exr" -- \
  "$bin" uvtools unwarp -q "$work/mean.png" --model "$work/m/model.safetensors" --coeffs "$work/badc.json" -o "$work/x.exr"

# Bad input: one line, exit 3, no model.
broken() {  # broken NAME: a copy of the registered set to break
  cp -r "$work/r" "$work/b_$1"
  echo "$work/b_$1"
}
expect_error() {  # expect_error NAME NEEDLE mm-build-args...
  local name=$1 needle=$2
  shift 2
  expect_failure 3 "$needle" "$work/out_$name/model.safetensors" -- build "$@" -o "$work/out_$name/model.safetensors"
}
d=$(broken vertices)
$py -c "import sys; p=sys.argv[1]; l=open(p).readlines(); i=max(k for k,x in enumerate(l) if x.startswith('v ')); open(p,'w').writelines(l[:i+1]+[l[i]]+l[i+1:])" \
  "$d/subject_0003/mesh.obj"
expect_error vertices "vertices, the template" --registered "$d"
d=$(broken triangles)
$py -c "import sys; p=sys.argv[1]; l=open(p).readlines(); i=[k for k,x in enumerate(l) if x.startswith('f ')]; l[i[0]],l[i[1]]=l[i[1]],l[i[0]]; open(p,'w').writelines(l)" \
  "$d/subject_0002/mesh.obj"
expect_error triangles "different triangle list" --registered "$d"
d=$(broken nan)
sed -i '0,/^v /s/^v [^ ]*/v nan/' "$d/subject_0001/mesh.obj"
expect_error nan "subject_0001/mesh.obj" --registered "$d"
mkdir -p "$work/b_few" && cp -r "$work/r/subject_0000" "$work/r/subject_0001" "$work/b_few/"
expect_error few "at least 3 subjects" --registered "$work/b_few"
mkdir -p "$work/b_same" && for k in 1 2 3 4; do cp -r "$work/r/subject_0000" "$work/b_same/subject_$k"; done
expect_error same "no variance" --registered "$work/b_same"
expect_error components "50 components asked" --registered "$work/r" --shape-components 50
# Geometry without maps (photogrammetry gives a diffuse map or none): a subject without a diffuse map is left out of
# the appearance model and named; the appearance mean is then the numpy mean of the other seven maps. With no maps
# at all there is no appearance model (a warning), or one line and exit 3 when a component count was asked for.
d=$(broken nomap)
rm "$d/subject_0004/diffuse.png"
build --registered "$d" -o "$work/out_nomap/model.safetensors" 2> "$work/err" || fail "nomap: $(cat "$work/err")"
grep -q "1 of 8 subjects have no diffuse map (subject_0004)" "$work/err" || fail "nomap: no warning: $(cat "$work/err")"
$py - "$here/../python" "$d" "$work/out_nomap" <<'PY' || fail "nomap: appearance model"
import json, os, sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import read
from safetensors_oracle import read_safetensors
from mm_oracle import srgb_to_linear
reg, out = sys.argv[2], sys.argv[3]
summary = json.load(open(out + "/model.build.json"))
assert summary["subjects_without_diffuse"] == ["subject_0004"], summary["subjects_without_diffuse"]
assert summary["appearance_subjects"] == 7 and summary["subjects"] == 8, summary
t = read_safetensors(out + "/model.safetensors")[1]
R = t["appearance_mean"].shape[0]
mask = t["appearance_mask"].astype(bool)
maps = [f"{reg}/{s}/diffuse.png" for s in sorted(os.listdir(reg)) if os.path.exists(f"{reg}/{s}/diffuse.png")]
assert len(maps) == 7
def box(path):  # the map box-filtered to R x R in linear light
    img = srgb_to_linear(read(path)[..., :3])
    f = img.shape[0] // R
    return img.reshape(R, f, R, f, 3).mean((1, 3))
acc = sum(box(p) for p in maps) / 7
err = np.abs(acc[mask] - t["appearance_mean"][mask]).max()
assert err < 1e-4, err
print(f"ok   mm-build without one diffuse map: appearance mean of the 7 with maps, max difference {err:.2e}")
PY
d=$(broken nomaps)
rm "$d"/subject_*/diffuse.png
build --registered "$d" -o "$work/out_nomaps/model.safetensors" 2> "$work/err" || fail "nomaps: $(cat "$work/err")"
grep -q "0 of 8 subjects have a diffuse map" "$work/err" || fail "nomaps: no warning: $(cat "$work/err")"
$py -c "import json,sys; s=json.load(open(sys.argv[1])); assert s['components']['appearance'] == 0, s" \
  "$work/out_nomaps/model.build.json" || fail "nomaps: an appearance model from no maps"
expect_error nomaps_asked "0 of 8 subjects have a diffuse map" --registered "$d" --appearance-components 3

# kill -9 while registering, rerun: identical model (same paths, so the same provenance line).
clean_build() { build "$work/s" --registered "$work/k/registered" --maps-res 64 -o "$work/k/model.safetensors"; }
clean_build || fail "mm-build from scans"
mv "$work/k/model.safetensors" "$work/reference.safetensors" && rm -rf "$work/k"
"$bin" mm-build -q --template "$work/t" --appearance-res 32 "$work/s" --registered "$work/k/registered" --maps-res 64 \
  -o "$work/k/model.safetensors" &  # clean_build's flags, the binary itself in the background (kill -9 must end it)
pid=$!
for _ in $(seq 200); do
  [ "$(ls "$work/k/registered" 2> /dev/null | grep -c subject_)" -ge 2 ] && break
  sleep 0.05
done
kill -9 $pid 2> /dev/null
wait $pid 2> /dev/null
[ -e "$work/k/model.safetensors" ] && fail "killed build left a model"
[ "$(ls "$work/k/registered" | grep -c subject_)" -lt 8 ] || fail "kill came too late to test resuming"
clean_build || fail "resumed mm-build"
cmp -s "$work/reference.safetensors" "$work/k/model.safetensors" || fail "resumed model differs"
echo "17 passed, 0 failed"
