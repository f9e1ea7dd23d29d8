#!/usr/bin/env bash
# make demo: runs the toolkit end to end on the built-in data and writes an HTML report with pictures.
# Every stage is skipped when its output already exists (outputs are written atomically), so a killed demo resumes.
set -euo pipefail
bin=${1:-build/bin}
out=${2:-out/demo}
mkdir -p "$out/img"
bareskin="$bin/bareskin"
stage() { echo "demo: $*" >&2; }
timed() {  # timed NAME command...: runs, records seconds in $out/timings.txt
  local name=$1 start=$EPOCHREALTIME
  shift
  "$@"
  /usr/bin/python3 -c "import sys; print(f'{sys.argv[1]:<12} {float(sys.argv[3]) - float(sys.argv[2]):7.1f} s')" \
    "$name" "$start" "$EPOCHREALTIME" >> "$out/timings.txt"
}

# 1. Template face (setup asset) -------------------------------------------------------------------------------------
if [ ! -f "$out/template/face.obj" ]; then
  stage "building the template face"
  timed template "$bareskin" template -o "$out/template"
else
  stage "template exists, skipping"
fi
for view in front left right; do
  [ -f "$out/img/template_$view.png" ] || "$bareskin" render "$out/template/face.obj" --view "$view" --size 1024 \
      --landmarks "$out/template/landmarks.json" -o "$out/img/template_$view.png"
done
[ -f "$out/img/template_uv.png" ] || "$bareskin" render "$out/template/face.obj" --view uv --size 2048 \
    --landmarks "$out/template/landmarks.json" -o "$out/img/template_uv.png"
[ -f "$out/img/template_full.png" ] || "$bareskin" render "$out/template/face.obj" --view front --size 4096 \
    --landmarks "$out/template/landmarks.json" -o "$out/img/template_full.png"
# 2. Synthetic scan population: geometry, maps in each scan's own atlas, truth, blendshapes -----------------------------
subjects=${DEMO_SUBJECTS:-10}
map_res=${DEMO_MAP_RES:-1024}
if [ ! -f "$out/scans/manifest.json" ]; then
  stage "synthesising $subjects scans (maps at $map_res)"
  timed "scan synth" "$bareskin" scan synth --template "$out/template" --count "$subjects" --seed 1 --vertices 100000 \
    --res "$map_res" --truth-res 1024 --holes -o "$out/scans"
fi
sheet=""
for dir in "$out"/scans/subject_*/; do
  id=$(basename "$dir")
  for view in front left; do
    [ -f "$out/img/${id}_$view.png" ] || "$bareskin" render "$dir/mesh.obj" --texture "$dir/diffuse.png" --view "$view" \
        --size 512 --no-wireframe -o "$out/img/${id}_$view.png"
  done
  caption=$(/usr/bin/python3 - "$dir" <<'PY2'
import json, sys
t = json.load(open(sys.argv[1] + "/truth/identity.json"))
a = t["appearance"]
print(f'{t["scan_triangles"]} triangles · melanin {a["melanin"]:.2f} · freckles {a["freckles"]:.2f}')
PY2
)
  sheet+="<figure><img src=\"img/${id}_front.png\" style=\"width:160px\"><img src=\"img/${id}_left.png\" style=\"width:160px\"><figcaption>$id · $caption</figcaption></figure>"
done
first="$out/scans/subject_0000"
maps=""
for m in diffuse normal roughness specular; do
  case $m in roughness|specular) channels=Y,Y,Y ;; *) channels=R,G,B ;; esac
  [ -f "$out/img/map_$m.png" ] || oiiotool "$first/$m.png" --resize 512x512 --ch "$channels" -d uint8 -o "$out/img/map_$m.png"
  maps+="<figure><a href=\"scans/subject_0000/$m.png\"><img src=\"img/map_$m.png\" style=\"width:220px\"></a><figcaption>$m</figcaption></figure>"
done
[ -f "$out/img/map_normal_detail.png" ] || oiiotool "$first/normal.png" --cut 192x192+400+300 --subc 0.5,0.5,1 \
    --mulc 6,6,6 --addc 0.5,0.5,1 --resize 384x384 -d uint8 -o "$out/img/map_normal_detail.png"
maps+="<figure><img src=\"img/map_normal_detail.png\" style=\"width:220px\"><figcaption>normal detail, tilt ×6</figcaption></figure>"
[ -f "$out/img/scan_uv.png" ] || "$bareskin" render "$first/mesh.obj" --view uv --size 1024 -o "$out/img/scan_uv.png"
maps+="<figure><img src=\"img/scan_uv.png\" style=\"width:220px\"><figcaption>the scan's own atlas</figcaption></figure>"
expressions=""
for e in jawOpen=1 mouthSmile_L=1,mouthSmile_R=1 eyeBlink_L=1 browInnerUp=1 mouthPucker=1 noseSneer_L=1,noseSneer_R=1; do
  name=${e//[=,]/_}
  [ -f "$out/img/expr_$name.png" ] || "$bareskin" render "$out/template/face.obj" --no-wireframe --size 512 \
      --blendshapes "$out/scans/blendshapes/blendshapes.safetensors" --expression "$e" -o "$out/img/expr_$name.png"
  expressions+="<figure><img src=\"img/expr_$name.png\" style=\"width:200px\"><figcaption>${e//,/ }</figcaption></figure>"
done
blendshape_names=$(/usr/bin/python3 -c "import json,sys; n=json.load(open(sys.argv[1])); print(len(n), 'shapes:', ', '.join(n))" \
  "$out/scans/blendshapes/names.json")
spread=$(/usr/bin/python3 - "$out/scans" <<'PY'
import glob, json, struct, sys
import numpy as np
rms = []
for f in sorted(glob.glob(sys.argv[1] + "/subject_*/truth/correspondence.safetensors")):
    raw = open(f, "rb").read()
    n = struct.unpack("<Q", raw[:8])[0]
    h = json.loads(raw[8:8 + n])
    b, e = h["identity_displacement"]["data_offsets"]
    d = np.frombuffer(raw[8 + n + b:8 + n + e], dtype="<f4").reshape(-1, 3)
    rms.append(np.sqrt((d ** 2).sum(1).mean()))
lum = []
for f in sorted(glob.glob(sys.argv[1] + "/subject_*/truth/identity.json")):
    lum.append(json.load(open(f))["appearance"]["melanin"])
print(f"{len(rms)} subjects; RMS distance from the template {np.mean(rms):.1f} mm (min {np.min(rms):.1f}, max {np.max(rms):.1f}); "
      f"melanin {np.min(lum):.2f} to {np.max(lum):.2f}")
PY
)

# 3. Registration of the population onto the template ----------------------------------------------------------------
if [ ! -f "$out/registered/summary.json" ]; then
  stage "registering $subjects scans"
  timed "scan register" "$bareskin" scan register --template "$out/template" --scans "$out/scans" -o "$out/registered"
fi
[ -f "$out/img/transfer_error.png" ] || oiiotool "$out/registered/subject_0000/diffuse.png" \
    "$out/scans/subject_0000/truth/maps/diffuse.png" --absdiff --mulc 8 -d uint8 -o "$out/img/transfer_error.png"
registration=$(/usr/bin/python3 - "$out/registered/summary.json" <<'PY2'
import json, sys
rows = json.load(open(sys.argv[1]))["scans"]
out = ["<table><tr><th>scan</th><th>alignment</th><th>correspondence error median / p95 / max (mm)</th>"
       "<th>surface distance median / p95 (mm)</th><th>landmarks mean (mm)</th><th>diffuse PSNR (dB) / normal error median (°), 1K maps</th>"
       "<th>time (s)</th><th>QA: error heat map</th></tr>"]
for r in rows:
    c, d = r.get("correspondence_error_mm", {}), r["surface_distance_mm"]
    out.append(f"<tr><td>{r['subject']}</td><td>{r['alignment'].split(' (')[0]}</td>"
               f"<td>{c.get('median', 0):.2f} / {c.get('p95', 0):.2f} / {c.get('max', 0):.2f}</td>"
               f"<td>{d['median']:.3f} / {d['p95']:.3f}</td><td>{r.get('landmark_error_mm', {}).get('mean', 0):.2f}</td>"
               + (f"<td>{r['maps']['vs_truth']['diffuse_psnr_db']:.1f} / {r['maps']['vs_truth']['normal_angle_median_deg']:.2f}</td>"
                  if "vs_truth" in r.get("maps", {}) else "<td>–</td>") +
               f"<td>{r['seconds']['total']:.1f}</td><td><img src=\"registered/{r['subject']}/qa_front.png\" style=\"width:110px;border:0\">"
               f"<img src=\"registered/{r['subject']}/qa_left.png\" style=\"width:110px;border:0\"></td></tr>")
print("\n".join(out + ["</table>"]))
PY2
)

# 4. Morphable model from the registered population (mm-build reuses the registrations above) --------------------------
if [ ! -f "$out/model/model.safetensors" ]; then
  stage "building the morphable model"
  timed "mm-build" "$bareskin" mm-build "$out/scans" --template "$out/template" --registered "$out/registered" \
      -o "$out/model/model.safetensors" --export-obj "$out/model/obj"
fi
if [ ! -f "$out/model/model_metrics/metrics.csv" ]; then
  timed "mm-eval" "$bareskin" mm-eval "$out/model/model.safetensors" "$out/registered"
fi
sweeps=""
for name in mean shape1_minus3sd shape1_plus3sd shape2_minus3sd shape2_plus3sd shape3_minus3sd shape3_plus3sd expression1_plus3sd expression2_plus3sd; do
  for view in front left; do
    [ -f "$out/img/model_${name}_$view.png" ] || "$bareskin" render "$out/model/obj/$name.obj" --no-wireframe --size 384 \
        --texture "$out/model/obj/appearance_mean.png" --view "$view" -o "$out/img/model_${name}_$view.png"
  done
  sweeps+="<figure><img src=\"img/model_${name}_front.png\" style=\"width:120px;border:0\"><img src=\"img/model_${name}_left.png\" style=\"width:120px;border:0\"><figcaption>${name//_/ }</figcaption></figure>"
done
model_renders=""
for c in 'mean:{}' 'alpha1+2:{"alpha":[2]}' 'alpha2-2, beta2+2, turned:{"alpha":[0,-2],"beta":[0,2],"rotation":[0,0.4,0]}' \
         'delta1+2,lit from the side:{"delta":[2],"rotation":[0,-0.3,0],"gamma":[0.8,0,0.1,-0.4,0,0,0,0,0,0.8,0,0.1,-0.4,0,0,0,0,0,0.8,0,0.1,-0.4,0,0,0,0,0]}'; do
  label=${c%%:*} json=${c#*:} name=$(echo "$label" | tr -c 'a-z0-9\n' '_')
  echo "$json" > "$out/model/coeffs_$name.json"
  [ -f "$out/img/model_render_$name.png" ] || "$bareskin" render --model "$out/model/model.safetensors" \
      --coeffs "$out/model/coeffs_$name.json" --camera pinhole --size 256 -o "$out/img/model_render_$name.png"
  model_renders+="<figure><img src=\"img/model_render_$name.png\" style=\"width:160px\"><figcaption>$label</figcaption></figure>"
done
# mm-fit: a render at known coefficients, its projected landmarks, the fit, and the fit rendered again.
if [ ! -f "$out/model/fit.json" ]; then
  echo '{"alpha":[1.5,-1,0.8,0.5,-0.7,0.3],"beta":[1],"delta":[-1],"rotation":[0.05,0.3,-0.04],"translation":[4,-6,15]}' \
      > "$out/model/fit_truth.json"
  "$bareskin" render --model "$out/model/model.safetensors" --coeffs "$out/model/fit_truth.json" --camera pinhole \
      --size 256 --landmarks-out "$out/model/fit_landmarks.json" -o "$out/img/fit_truth.png"
  timed "mm-fit" "$bareskin" mm-fit "$out/img/fit_truth.png" --model "$out/model/model.safetensors" \
      --landmarks "$out/model/fit_landmarks.json" -o "$out/model/fit.json" --trace "$out/model/fit_trace.csv"
  "$bareskin" render --model "$out/model/model.safetensors" --coeffs "$out/model/fit.json" --camera pinhole --size 256 \
      -o "$out/img/fit_result.png"
  oiiotool "$out/img/fit_truth.png" "$out/img/fit_result.png" --absdiff --mulc 4 -o "$out/img/fit_diff.png"
fi
# mm-fit --skin-mask: the same render with a glove over the cheek, fitted with every face pixel and with the glove masked.
if [ ! -f "$out/model/fit_occluded_skin.json" ]; then
  /usr/bin/python3 - "$out/img/fit_truth.png" "$out/img" <<'PY6'
import sys
import numpy as np, skimage.io as io
img = io.imread(sys.argv[1])
yy, xx = np.mgrid[0:img.shape[0], 0:img.shape[1]]
glove = ((xx - 95) / 38.0) ** 2 + ((yy - 150) / 55.0) ** 2 < 1
img[glove, :3] = [200, 170, 90]
io.imsave(f"{sys.argv[2]}/fit_occluded.png", img, check_contrast=False)
io.imsave(f"{sys.argv[2]}/fit_occluded_skin.png", np.where(glove, 0, 255).astype(np.uint8), check_contrast=False)
PY6
  for m in all skin; do
    extra=()
    [ $m = skin ] && extra=(--skin-mask "$out/img/fit_occluded_skin.png")
    "$bareskin" mm-fit "$out/img/fit_occluded.png" --model "$out/model/model.safetensors" \
        --landmarks "$out/model/fit_landmarks.json" -o "$out/model/fit_occluded_$m.json" "${extra[@]}"
    "$bareskin" render --model "$out/model/model.safetensors" --coeffs "$out/model/fit_occluded_$m.json" --camera pinhole \
        --size 256 -o "$out/img/fit_occluded_$m.png"
  done
fi
occluded_summary=$(/usr/bin/python3 - "$out/model/fit_truth.json" "$out/model/fit_occluded_all.json" "$out/model/fit_occluded_skin.json" <<'PY7'
import json, sys
t, a, s = (json.load(open(p)) for p in sys.argv[1:4])
def err(f):
    return max(abs(x - y) for x, y in zip(t["delta"] + [0] * len(f["delta"]), f["delta"]))
def amb(f):
    return ", ".join(f"{f['gamma'][9 * c]:.2f}" for c in range(3))
print(f"with every face pixel, δ is off by up to {err(a):.2f} σ and the ambient light comes out ({amb(a)}) for a true "
      f"(0.80, 0.80, 0.80), PSNR {a['photometric_psnr_db']:.1f} dB; with the glove masked out ({s['photometric_pixels']} of "
      f"{a['photometric_pixels']} pixels), δ is within {err(s):.3f} σ, the ambient light ({amb(s)}), PSNR "
      f"{s['photometric_psnr_db']:.1f} dB")
PY7
)
fit_summary=$(/usr/bin/python3 - "$out/model/fit_truth.json" "$out/model/fit.json" "$out/model/model.safetensors" \
    "$(dirname "$0")/../tests/python" <<'PY5'
import json, sys
import numpy as np
sys.path.insert(0, sys.argv[4])
from safetensors_oracle import read_safetensors
t, f = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
_, model = read_safetensors(sys.argv[3])
def shape(c):  # the model's shape at α, β (standardised), before the pose
    s = model["shape_mean"].astype(np.float64)
    for key, basis, sd in (("alpha", "shape_basis", "shape_stddev"), ("beta", "expression_basis", "expression_stddev")):
        for j, v in enumerate(c.get(key, [])[:len(model[sd])]):
            s = s + v * float(model[sd][j]) * model[basis][j].astype(np.float64)
    return s
err = np.linalg.norm(shape(t) - shape(f), axis=1)
da = max(abs(a - b) for a, b in zip(t["alpha"] + [0] * len(f["alpha"]), f["alpha"]))
dr = max(abs(a - b) for a, b in zip(t["rotation"], f["rotation"]))
db = max(abs(a - b) for a, b in zip(t["beta"] + [0] * len(f["beta"]), f["beta"]))
dd = max(abs(a - b) for a, b in zip(t["delta"] + [0] * len(f["delta"]), f["delta"]))
print(f"landmark reprojection {f['landmark_rms_px']:.3f} px RMS at 256², {f['iterations']} iterations, "
      f"{1000 * f['seconds']:.1f} ms; shape error vs truth {np.median(err):.2f} mm median, {err.max():.2f} mm max over "
      f"{len(err)} vertices; largest error: α {da:.3f} σ, β {db:.3f} σ, rotation {dr * 180 / 3.14159265:.3f}°, "
      f"translation {max(abs(a - b) for a, b in zip(t['translation'], f['translation'])):.2f} mm; then the photometric "
      f"term: δ within {dd:.3f} σ, the ambient light {f['gamma'][0]:.3f} (true 0.8), render PSNR "
      f"{f['photometric_psnr_db']:.1f} dB over {f['photometric_pixels']} face pixels")
PY5
)
appearance=""
for name in appearance_mean appearance1_minus3sd appearance1_plus3sd appearance2_minus3sd appearance2_plus3sd; do
  appearance+="<figure><img src=\"model/obj/$name.png\" style=\"width:180px\"><figcaption>${name//_/ }</figcaption></figure>"
done
model_summary=$(/usr/bin/python3 - "$out/model/model.build.json" "$out/model/model_metrics/metrics.json" <<'PY3'
import json, sys
b, m = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
c, s = b["components"], b["seconds"]
print(f"{b['subjects']} subjects; {c['shape']} identity, {c['expression']} expression and {c['appearance']} appearance "
      f"components ({100 * b['variance_explained']['shape']:.1f}% / {100 * b['variance_explained']['appearance']:.1f}% of "
      f"the shape / appearance variance); build {s['total']:.1f} s (registration cache reused: {s['register']:.1f} s; "
      f"read {s['read_shapes']:.1f}, GPA {s['gpa']:.2f}, shape PCA {s['shape_pca']:.2f}, maps {s['read_maps']:.1f}, "
      f"appearance PCA {s['appearance_pca']:.2f}, expression {s['expression']:.1f}). "
      f"At {m['components'][-1]} components: generalisation {m['generalization_mm'][-1]:.2f} mm, specificity "
      f"{m['specificity_mm'][-1]:.2f} mm ({m['samples']} samples), compactness {m['compactness'][-1]:.3f}.")
PY3
)

# 5. uvtools bake: the first subject's transferred 1K maps to 512 and 256, seam-aware ---------------------------------
if [ ! -f "$out/baked/bake.json" ]; then
  stage "baking maps to 512 and 256"
  timed "uvtools bake" "$bareskin" uvtools bake "$out/registered/subject_0000" -o "$out/baked" --sizes 512,256 \
      --format png --layout "$out/template/face.obj"
fi
reg0="$out/registered/subject_0000"
if [ ! -f "$out/img/bake_ours.png" ]; then
  oiiotool "$reg0/diffuse.png" --cut 128x128+448+896 --resample 256x256 -o "$out/img/bake_input.png"
  oiiotool "$reg0/diffuse.png" --colorconvert sRGB linear --resize:filter=box 256x256 --colorconvert linear sRGB \
      --cut 32x32+112+224 --resample 256x256 -o "$out/img/bake_naive.png"
  oiiotool "$out/baked/256/diffuse.png" --cut 32x32+112+224 --resample 256x256 -o "$out/img/bake_ours.png"
  oiiotool "$out/baked/256/normal.png" --resize 512x512 -o "$out/img/bake_normal.png"
fi
bake_summary=$(/usr/bin/python3 -c "import json,sys; b=json.load(open(sys.argv[1])); print(f\"{len(b['maps'])} maps {b['input_size']}² → {', '.join(str(s) for s in b['sizes'])} in {b['seconds']:.1f} s; {100 * b['island_fraction']:.1f}% of texels in UV islands; {b['flipped_uv_triangles']} flipped UV triangles in the template\")" "$out/baked/bake.json")

# 6. Renderer: every scan from three views, with and without light (one rasterization per view) ----------------------
renders=""
for dir in "$out"/scans/subject_*/; do
  id=$(basename "$dir")
  [ -f "$out/img/render_${id}_right_colour.png" ] || "$bareskin" render "$dir/mesh.obj" --texture "$dir/diffuse.png" \
      --camera pinhole --views front,left,right --passes colour,albedo --size 224 -o "$out/img/render_${id}_{view}_{pass}.png"
  cells=""
  for v in front left right; do cells+="<img src=\"img/render_${id}_${v}_colour.png\" style=\"width:112px;border:0\">"; done
  cells+="<img src=\"img/render_${id}_front_albedo.png\" style=\"width:112px;border:0\">"
  renders+="<figure>$cells<figcaption>$id: lit front / left / right · albedo</figcaption></figure>"
done
[ -f "$out/img/render_passes_depth.png" ] || "$bareskin" render "$out/scans/subject_0000/mesh.obj" --camera pinhole \
    --passes depth,normal,mask --size 224 -o "$out/img/render_passes_{pass}.png"
# The differentiable render (render/torch): batch 4 of the template, forward and backward, on this machine (and on a
# GPU where the build has the CUDA rasterizer and one is present).
if [ -x "$bin/render_torch_bench" ] && [ ! -f "$out/img/differentiable_render.txt" ]; then
  "$bin/render_torch_bench" "$out/template" 3 > "$out/img/differentiable_render.txt"
fi
differentiable=$( [ -f "$out/img/differentiable_render.txt" ] && sed 's/&/\&amp;/g; s/</\&lt;/g' "$out/img/differentiable_render.txt" \
    || echo "(built without LibTorch)")
[ -f "$out/img/render_landmarks_left.png" ] || "$bareskin" render "$out/registered/subject_0000/mesh.ply" \
    --texture "$out/registered/subject_0000/diffuse.png" --landmarks "$out/template/landmarks.json" --camera pinhole \
    --views front,left,right --size 224 --draw-landmarks -o "$out/img/render_landmarks_{view}.png"

# 7. uvtools unwarp: renders of the first registered subject back into the template UV, with visibility ---------------
mkdir -p "$out/unwarp"
for v in front left; do
  [ -f "$out/unwarp/render_$v.png" ] || "$bareskin" render "$reg0/mesh.ply" --texture "$reg0/diffuse.png" --camera pinhole \
      --views "$v" --passes albedo --size 1024 -o "$out/unwarp/render_$v.png"
  [ -f "$out/unwarp/uv_$v.png" ] || "$bareskin" uvtools unwarp "$out/unwarp/render_$v.png" --mesh "$reg0/mesh.ply" \
      --view "$v" --size 1024 -o "$out/unwarp/uv_$v.png"
done
occluders=""
seed=1
for o in hair glasses hand hat hair,glasses,hand; do
  name=${o//,/_}
  if [ ! -f "$out/unwarp/mask_$name.png" ]; then
    "$bareskin" uvtools mask -q --mesh "$reg0/mesh.ply" --synthetic "$o" --landmarks "$out/template/landmarks.json" \
        --seed "$seed" --image-size 512 --size 512 --labels-out "$out/unwarp/labels_$name.png" -o "$out/unwarp/mask_$name.png"
    oiiotool "$out/unwarp/labels_$name.png" --mulc 12 -o "$out/img/labels_$name.png"
  fi
  occluders+="<figure><img src=\"img/labels_$name.png\" style=\"width:130px\"><img src=\"unwarp/mask_$name.png\" style=\"width:130px\"><figcaption>${o//,/ + }</figcaption></figure>"
  seed=$((seed + 1))
done
unwarp_summary=$(/usr/bin/python3 - "$(dirname "$0")/../tests/python" "$out/unwarp" "$reg0/diffuse.png" <<'PY4'
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import read
t = read(sys.argv[3])[..., :3]
out = []
for v in ("front", "left"):
    u, c = read(f"{sys.argv[2]}/uv_{v}.png")[..., :3], read(f"{sys.argv[2]}/uv_{v}_confidence.png")[..., 0]
    seen, good = c > 0, c > 0.5
    p = lambda m: 10 * np.log10(1 / ((u - t)[m] ** 2).mean())
    out.append(f"{v}: {seen.sum()} texels seen, PSNR {p(seen):.1f} dB against the texture ({p(good):.1f} dB where the "
               f"confidence is over 0.5)")
print("; ".join(out))
PY4
)

# 8. Landmarks: face-api's networks on a photo, and 3D landmarks of every scan from its front render ------------------
mkdir -p "$out/landmarks"
astronaut=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
[ -f "$out/landmarks/astronaut.json" ] || timed "landmarks detect" "$bareskin" landmarks detect "$astronaut" \
    -o "$out/landmarks/astronaut.json" --draw "$out/img/landmarks_astronaut.png"
lm_cells=""
for dir in "$out"/scans/subject_*/; do
  id=$(basename "$dir")
  [ -f "$out/landmarks/$id.json" ] || "$bareskin" landmarks scan -q "$dir" -o "$out/landmarks/$id.json" \
      --draw "$out/img/landmarks_$id.png"
done
landmark_summary=$(/usr/bin/python3 - "$out" <<'PY5'
import glob, json, os, sys
import numpy as np
out = sys.argv[1]
a = json.load(open(f"{out}/landmarks/astronaut.json"))
rows, all_e = [], []
for f in sorted(glob.glob(f"{out}/landmarks/subject_*.json")):
    sid = os.path.basename(f)[:-5]
    d = np.array(json.load(open(f))["points"])
    t = np.array(json.load(open(f"{out}/scans/{sid}/landmarks.json"))["points"])
    e = np.linalg.norm(d - t, axis=1)
    all_e.append(e)
    rows.append(f"<tr><td>{sid}</td><td>{np.median(e):.1f}</td><td>{np.median(e[17:]):.1f}</td>"
                f"<td>{np.median(e[:17]):.1f}</td></tr>")
e = np.array(all_e)
print(f"<p>astronaut.png: {len(a['faces'])} face, score {a['score']:.3f}. Scans: 3D error of the detected landmarks "
      f"against the truth, median over all {e.size} points {np.median(e):.1f} mm; without the jaw contour (17-67) "
      f"{np.median(e[:, 17:]):.1f} mm; jaw contour {np.median(e[:, :17]):.1f} mm.</p>")
print("<table><tr><th>scan</th><th>median (mm)</th><th>17-67</th><th>jaw 0-16</th></tr>" + "".join(rows) + "</table>")
PY5
)

# Registration from detected landmarks (subjects 8-9 without their landmarks.json; the detector calibrated on 0-4), and
# texture landmarks against the mean diffuse of the registered subjects 0-7.
calib="$out/landmarks/calib16.json"
[ -f "$calib" ] || timed "landmarks calibrate" "$bareskin" landmarks calibrate -q --scans "$out/scans" -o "$calib" \
    --views 16 --count 5
for id in subject_0008 subject_0009; do
  d="$out/detected_scans/$id"
  [ -d "$d" ] || { mkdir -p "$d.tmp" && for f in "$out/scans/$id"/*; do [ "$(basename "$f")" = landmarks.json ] || cp -al "$f" "$d.tmp/"; done && mv "$d.tmp" "$d"; }
done
[ -f "$out/landmarks/reference.png" ] || "$bareskin" -q uvtools mean -o "$out/landmarks/reference.png" \
    "$out"/registered/subject_000[0-7]/diffuse.png
[ -f "$out/registered_detected/summary.json" ] || timed "register (detected)" "$bareskin" scan register -q \
    --template "$out/template" --scans "$out/detected_scans" -o "$out/registered_detected" --maps-res 0 \
    --landmark-calibration "$calib"
[ -f "$out/registered_texture/summary.json" ] || timed "register (texture landmarks)" "$bareskin" scan register -q \
    --template "$out/template" --scans "$out/detected_scans" -o "$out/registered_texture" --maps-res 0 \
    --landmark-calibration "$calib" --texture-landmarks 3 --texture-reference "$out/landmarks/reference.png" \
    --outline-weight 0.3
texture_landmarks=$(/usr/bin/python3 - "$out" <<'PY6'
import json, sys
out = sys.argv[1]
rows = ["<table><tr><th>scan</th><th>detected landmarks vs truth, median 17-67 (mm)</th>"
        "<th>NICP from them: correspondence median / p95 (mm)</th><th>+ texture landmarks (3 rounds, with shape points) and the outline term: median / p95</th>"
        "<th>found points vs truth (mm)</th><th>heat maps (blue 0, red 2 mm): detected / texture landmarks</th></tr>"]
for sid in ("subject_0008", "subject_0009"):
    a = json.load(open(f"{out}/registered_detected/{sid}/report.json"))
    b = json.load(open(f"{out}/registered_texture/{sid}/report.json"))
    ca, cb, t = a["correspondence_error_mm"], b["correspondence_error_mm"], b["texture_landmarks"]
    rows.append(f"<tr><td>{sid}</td><td>{a['landmarks_detected']['error_vs_truth_mm']['median_17_67']:.2f}</td>"
                f"<td>{ca['median']:.2f} / {ca['p95']:.2f}</td><td>{cb['median']:.2f} / {cb['p95']:.2f}</td>"
                f"<td>{t['found'][-1]} found, {t['error_mm']['median']:.2f}; {t['shape_points']['found'][-1]} shape points, "
                f"{t['shape_points']['error_mm']['median']:.2f}</td>"
                f"<td><img src=\"registered_detected/{sid}/qa_front.png\" style=\"width:130px;border:0\">"
                f"<img src=\"registered_texture/{sid}/qa_front.png\" style=\"width:130px;border:0\"></td></tr>")
print("\n".join(rows + ["</table>"]))
PY6
)

# The network zoo the coming trainings build on (each net constructed at the paper's size and counted).
zoo=$("$bareskin" train --list-models | sed 's/&/\&amp;/g; s/</\&lt;/g')

# 10+. The training world's sections: each scripts/demo/NN_*.sh runs its stages (skipping what exists), and writes its
# report fragment to $out/sections/NN_*.html and its timings to $out/timings.txt.
mkdir -p "$out/sections"
for section in "$(dirname "$0")"/demo/[0-9][0-9]_*.sh; do
  [ -f "$section" ] || continue
  stage "section $(basename "$section" .sh)"
  bash "$section" "$bin" "$out"
done
sections=$(cat "$out"/sections/[0-9][0-9]_*.html 2>/dev/null || true)

info=$("$bareskin" inspect --json "$out/template/face.obj")
st=$("$bareskin" inspect "$out/template/face.safetensors")
[ -f "$out/timings.txt" ] && timings=$(cat "$out/timings.txt") || timings=""

# 2. Report ----------------------------------------------------------------------------------------------------------
json() { echo "$info" | /usr/bin/python3 -c "import json,sys; print(json.load(sys.stdin)$1)"; }
cat > "$out/report.html" <<HTML
<!doctype html>
<html><head><meta charset="utf-8"><title>BareSkin toolkit — demo report</title>
<style>
body{font:15px/1.45 system-ui,sans-serif;max-width:1100px;margin:2em auto;color:#222}
h1{font-size:1.6em}h2{margin-top:2em;border-bottom:1px solid #ddd}
figure{display:inline-block;margin:.5em;text-align:center}figure img{width:340px;border:1px solid #ccc}
figcaption{font-size:.85em;color:#555}table{border-collapse:collapse}td:last-child{white-space:nowrap}td,th{padding:.2em .8em;border-bottom:1px solid #eee;text-align:left}
pre{background:#f6f6f6;padding:.8em;white-space:pre-wrap;font-size:.85em}.todo{color:#999}
</style></head><body>
<h1>BareSkin toolkit — demo report</h1>
<p>Generated $(date -u '+%Y-%m-%d %H:%M UTC') on $(uname -n) by <code>make demo</code> ($("$bareskin" --version)).
Sections 1–9 build the geometry half (template, scans, registration, morphable model, maps, renderer,
landmarks); the sections after them build the training world, train small networks on the CPU and evaluate them on
held-out subjects. Each section says which sizes it used and why.</p>

<h2>1. Template face</h2>
<p>The fixed topology every scan is registered to and the 3DMM is built on: the MediaPipe canonical face
(468 vertices, 898 triangles; npm <code>@mediapipe/face_mesh@0.4.1657299874</code>, Apache-2.0), decoded by our own
protobuf reader, converted to millimetres, refined by modified-butterfly subdivision and isotropic remeshing.
iBUG-68 landmarks (red) from <code>@vladmandic/human@3.3.6</code> (MIT).</p>
<table>
<tr><th>vertices</th><td>$(json '["vertices"]')</td><th>triangles</th><td>$(json '["triangles"]')</td></tr>
<tr><th>surface area</th><td>$(json '["surface_area"]' | xargs printf '%.0f') mm²</td><th>boundary edges</th><td>$(json '["boundary_edges"]')</td></tr>
<tr><th>bounding box (mm)</th><td colspan=3>$(json '["bounding_box"]' | /usr/bin/python3 -c "import ast,sys; b=ast.literal_eval(sys.stdin.read()); print(' to '.join('(' + ', '.join(f'{x:.1f}' for x in p) + ')' for p in b))")</td></tr>
</table>
<figure><a href="img/template_front.png"><img src="img/template_front.png"></a><figcaption>front (shaded + wireframe, landmarks)</figcaption></figure>
<figure><a href="img/template_left.png"><img src="img/template_left.png"></a><figcaption>left</figcaption></figure>
<figure><a href="img/template_right.png"><img src="img/template_right.png"></a><figcaption>right</figcaption></figure>
<figure><a href="img/template_uv.png"><img src="img/template_uv.png"></a><figcaption>UV layout (2048², click to zoom)</figcaption></figure>
<figure><a href="img/template_full.png"><img src="img/template_full.png"></a><figcaption>front at 4096² (click: wireframe detail)</figcaption></figure>
<p>Files: <a href="template/face.obj">face.obj</a>, <a href="template/landmarks.json">landmarks.json</a>,
<a href="template/regions.json">regions.json</a>, <a href="template/face.safetensors">face.safetensors</a>,
<a href="template/config.json">config.json</a>.</p>
<pre>$st</pre>

<h2>2. Synthetic scan population</h2>
<p><code>bareskin scan synth</code>: each subject is the template deformed by a sampled identity — a multi-scale Gaussian
process (squared-exponential kernels of 60, 25 and 10 mm, drawn with random Fourier features, 85% mirror-symmetric)
plus semantic controls (nose length/width/bridge, jaw width, chin, cheekbones, eye spacing, lip thickness, brow ridge) —
then remeshed into its own topology, with the true position of every template vertex on the scan stored in
<code>truth/correspondence.safetensors</code>. Each scan has its own UV atlas (two charts cut along the midline, warped,
turned and packed per subject) and four ${map_res}² maps baked from a procedural skin (melanin/haemoglobin albedo,
freckles, blemishes, blush, lips, brow hair; pores and forehead wrinkles in the tangent-space normal map; regional
roughness and specular) whose true value at every surface point is known. Nostrils are cut open (<code>--holes</code>;
the white in them is the background seen through the holes).
$spread. Front and profile, textured with each scan's diffuse map:</p>
$sheet
<h3>The four maps of subject_0000 (its own atlas)</h3>
$maps
<h3>Expression blendshapes (on the template)</h3>
<p>Standing in for the paper's 236 artist-made blendshapes: region-weighted, smooth displacements anchored at iBUG-68
landmarks, ARKit names ("_L" = the subject's left). Posed with
<code>bareskin render face.obj --blendshapes scans/blendshapes/blendshapes.safetensors --expression jawOpen=1</code>.
$blendshape_names.</p>
$expressions

<h2>3. Registration</h2>
<p><code>bareskin scan register</code>: a similarity from the 68 landmarks (Umeyama), then optimal-step non-rigid ICP
(Amberg et al. 2007) on about 2,000 nodes (the template remeshed) whose affine transforms the 65k-vertex template
blends. The stiffness asks neighbouring affines to agree at the nodes (embedded-deformation consistency, which does not
depend on where the origin is) plus a little of Amberg's affine difference; rejection by normal angle, scan boundary and a distance trim, Huber weights, CHOLMOD with the symbolic
analysis done once, and a final projection onto the scan. Errors are measured against the synthetic truth. Heat maps:
correspondence error per vertex, blue 0 to red 2 mm. The four maps are then transferred into the template UV at 1K
(closest scan point, its atlas UV, bilinear lookups; normals from the scan's tangent frames to the template's) and
compared with the truth maps baked directly in the template UV, away from the scan's atlas seams.</p>
$registration
<figure><img src="registered/subject_0000/diffuse.png" style="width:260px"><figcaption>subject_0000 diffuse, transferred into the template UV</figcaption></figure>
<figure><img src="scans/subject_0000/truth/maps/diffuse.png" style="width:260px"><figcaption>truth (baked in the template UV)</figcaption></figure>
<figure><img src="img/transfer_error.png" style="width:260px"><figcaption>|difference| ×8</figcaption></figure>

<h2>4. Morphable model</h2>
<p><code>bareskin mm-build scans/ -o model.safetensors</code> registers what is not registered yet (here: nothing, the
registrations above are reused), aligns the registered meshes by generalised Procrustes, and builds the identity shape
PCA (α), the appearance PCA of the diffuse maps in the template UV (δ; linear RGB, 256², masked to the UV layout) and the
expression basis (β) from the blendshapes moved onto the mean face and orthonormalised. $model_summary
Files: <a href="model/model.safetensors">model.safetensors</a>, <a href="model/model.build.json">model.build.json</a>,
<a href="model/model_metrics/metrics.csv">metrics.csv</a>.</p>
<h3>Mean and ±3σ along the first components (mean appearance)</h3>
$sweeps
<h3>The model rendered from coefficients (<code>render --model model.safetensors --coeffs fit.json --camera pinhole</code>)</h3>
<p>Shape (α), expression (β), appearance (δ), pose and SH lighting (γ) from one coefficient file, the format
<code>mm-fit</code> writes.</p>
$model_renders
<h3>Fitting to landmarks (<code>mm-fit image.png --model model.safetensors --landmarks lm.json</code>)</h3>
<p>Levenberg–Marquardt on pose and the first identity and expression components against the 68 landmarks,
regularised, then Gauss–Newton on appearance and SH lighting against the pixels (priors on both): $fit_summary.</p>
<figure><img src="img/fit_truth.png" style="width:200px"><figcaption>render at known coefficients</figcaption></figure>
<figure><img src="img/fit_result.png" style="width:200px"><figcaption>the fit, rendered (its α, β, δ, γ and pose)</figcaption></figure>
<figure><img src="img/fit_diff.png" style="width:200px"><figcaption>|difference| ×4</figcaption></figure>
<p>Accuracy against time, one marker per iteration (<code>mm-fit --trace fit_trace.csv</code>; the photometric clock
includes its set-up: rasterizing the fitted shape and the per-pixel SH basis):</p>
<figure><img src="model/fit_trace_landmarks.svg" style="width:340px"><figcaption>landmark term</figcaption></figure>
<figure><img src="model/fit_trace_photometric.svg" style="width:340px"><figcaption>photometric term</figcaption></figure>
<p>The photometric term on the skin region (<code>mm-fit --skin-mask skin.png</code>, white where the term may look,
e.g. a face parser's skin class): the same render with a glove over the cheek; $occluded_summary.</p>
<figure><img src="img/fit_occluded.png" style="width:200px"><figcaption>input: a glove over the cheek</figcaption></figure>
<figure><img src="img/fit_occluded_all.png" style="width:200px"><figcaption>fit with every face pixel</figcaption></figure>
<figure><img src="img/fit_occluded_skin.png" style="width:200px"><figcaption>fit with <code>--skin-mask</code> (glove masked)</figcaption></figure>
<h3>Appearance: mean and ±3σ along the first two components</h3>
$appearance
<h3>Metrics (<code>bareskin mm-eval</code>; RMS vertex distance in correspondence)</h3>
<figure><img src="model/model_metrics/compactness.svg" style="width:340px"><figcaption>compactness</figcaption></figure>
<figure><img src="model/model_metrics/generalization.svg" style="width:340px"><figcaption>generalisation (leave-one-out)</figcaption></figure>
<figure><img src="model/model_metrics/specificity.svg" style="width:340px"><figcaption>specificity</figcaption></figure>
<figure><img src="model/model_metrics/generalization_regions.svg" style="width:340px"><figcaption>generalisation per face region</figcaption></figure>

<h2>5. Maps resized for training (uvtools bake)</h2>
<p><code>bareskin uvtools bake registered/subject_0000 --sizes 512,256</code> reads each map a band of rows at a time and
writes every size from one read: each output texel averages the input texels under it that lie in a UV island of the
template (diffuse in linear light, normals as vectors then renormalised), then gutters are filled outward from the
islands. $bake_summary. A crop at the chin's rim, 256² output shown ×8:</p>
<figure><img src="img/bake_input.png" style="width:220px"><figcaption>input (1K)</figcaption></figure>
<figure><img src="img/bake_naive.png" style="width:220px"><figcaption>plain box resize: black bleeds into the rim</figcaption></figure>
<figure><img src="img/bake_ours.png" style="width:220px"><figcaption>uvtools bake: islands only, gutter filled</figcaption></figure>
<figure><img src="img/bake_normal.png" style="width:220px"><figcaption>baked normal map (256²)</figcaption></figure>

<h2>6. Renderer</h2>
<p><code>bareskin render mesh.obj --texture diffuse.png --camera pinhole --views front,left,right --passes colour,albedo</code>:
Deep3DFaceRecon's camera (focal 1015 px at 224², 1 m away), the tiled CPU rasterizer (perspective-correct barycentrics,
depth test), and order-2 SH lighting with Deep3DFaceRecon's basis (ambient 0.8 plus a soft key light); the albedo pass
comes from the same rasterization. 224² here.</p>
$renders
<figure><img src="img/render_passes_depth.png" style="width:160px"><img src="img/render_passes_normal.png" style="width:160px"><img src="img/render_passes_mask.png" style="width:160px"><figcaption>depth, camera-frame normals, mask</figcaption></figure>
<p>The same rasterizer inside LibTorch (<code>render/torch/ops.h</code>: rasterize without gradient, interpolate with
barycentrics recomputed from the vertex positions so gradients reach them, texture, SH shading), as training will run
it: the template, batch 4, per-frame vertex offsets, projection, normals, albedo × SH irradiance, an L2 loss and its
backward to positions, albedo and lighting (<code>render_torch_bench</code>, medians of 3):</p>
<pre>$differentiable</pre>
<figure><img src="img/render_landmarks_front.png" style="width:160px"><img src="img/render_landmarks_left.png" style="width:160px"><img src="img/render_landmarks_right.png" style="width:160px"><figcaption>registered subject_0000 with the template's 68 landmarks projected (<code>--draw-landmarks</code>; hidden points are drawn too)</figcaption></figure>

<h2>7. Images back into UV (uvtools unwarp)</h2>
<p><code>bareskin uvtools unwarp render.png --mesh mesh.ply --view left -o uv.png</code>: each texel's surface point is
projected into the image and kept when it matches the depth buffer of the same camera (occluded texels stay empty); the
colour is sampled bilinearly in linear light and the confidence is the cosine of the view angle. Round trip on
subject_0000 (registered mesh and its transferred diffuse, rendered at 1024² and unwarped at 1K): $unwarp_summary.</p>
<figure><img src="unwarp/render_left.png" style="width:220px"><figcaption>render, left view</figcaption></figure>
<figure><img src="unwarp/uv_left.png" style="width:220px"><figcaption>unwarped into the template UV</figcaption></figure>
<figure><img src="unwarp/uv_left_confidence.png" style="width:220px"><figcaption>confidence (black: unseen)</figcaption></figure>
<figure><img src="unwarp/uv_front.png" style="width:220px"><figcaption>front view, unwarped</figcaption></figure>
<p><code>bareskin uvtools mask --synthetic hair,glasses,hand --landmarks template/landmarks.json</code>: occluders drawn in
image space from the projected landmarks with random shapes (label images in CelebAMask-HQ's classes, brightened ×12),
and the UV masks of the face seen and uncovered they give (white); a real label image takes the same path.</p>
$occluders

<h2>8. Landmarks (face-api's networks in LibTorch)</h2>
<p><code>bareskin landmarks detect photo.png -o lm.json --draw lm.png</code>: the tiny face detector (416²) finds the
face, the 68-point network reads a 112² crop; outputs equal face-api's own JavaScript to 0.0001 px (tests/cli/landmarks.sh).
<code>bareskin landmarks scan scans/subject_0000 -o lm.json</code>: the scan rendered from the front, the landmarks found in
the render (box refined from the points), each back-projected onto the surface. <code>scan register</code> does this for
scans without <code>landmarks.json</code>.</p>
<figure><img src="img/landmarks_astronaut.png" style="width:300px"><figcaption>astronaut.png</figcaption></figure>
<figure><img src="img/landmarks_subject_0000.png" style="width:300px"><figcaption>subject_0000, front render</figcaption></figure>
<figure><img src="img/landmarks_subject_0001.png" style="width:300px"><figcaption>subject_0001, front render</figcaption></figure>
$landmark_summary
<h3>Registration from detected landmarks, and texture landmarks</h3>
<p><code>bareskin landmarks calibrate --scans scans --count 5 --views 16</code> learns the detector's convention on
subjects 0-4; subjects 8 and 9, without their <code>landmarks.json</code>, are registered from 16-view detected,
calibrated landmarks (<code>scan register --landmark-calibration</code>), then again with <code>--texture-landmarks 3
--texture-reference</code> (the mean diffuse of the registered subjects 0-7) and <code>--outline-weight 0.3</code>: the brows,
eyes and outer lip line are found in the scan's texture, the nose in its curvature, and the registration is run again
from them, with 2000 shape points (template vertices spread over the face, placed by the same curvature flow) holding
the chin and cheeks and the template's outline drawn to the scan's open border (these synthetic scans are cut along the
face outline; docs/pipeline.md, "Texture landmarks", "Outline term"). On six held-out noisy scans this takes the
correspondence median from 2.66 to 0.51 mm (0.74 without the shape points; bench/BENCHMARKS.md, "Shape points"); with
the true landmarks NICP gets about 0.5 mm.</p>
$texture_landmarks

<h2>9. Training foundation: the network zoo</h2>
<p>Every network the trainings of the coming stages use, built from options at the paper's sizes (smaller sizes for CPU
demos are options): <code>bareskin train --list-models</code>; <code>--print-model NAME</code> shows the options. The
counts equal the reference implementations' (torchvision, pix2pix, pix2pixHD, BasicSR), and exported weights load into
torchvision's ResNets with outputs equal to 5e-7 (tests/python/torchvision_oracle.py). They all train on one Trainer
(docs/training.md): checkpoints that resume bit for bit, NaN stop, loss charts, sample grids, TensorBoard, several GPUs.</p>
<pre>$zoo</pre>
$sections

<h2>Timings (this run; skipped stages not re-timed)</h2>
<pre>${timings:-all stages reused from an earlier run}</pre>
</body></html>
HTML
stage "report: $out/report.html"
