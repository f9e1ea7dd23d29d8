#!/usr/bin/env bash
# Demo §13: texgen make-dataset — the texture-inference training data (train/val/test texture shards and masks/) from
# the registered demo subjects and the demo model; one sample's inputs next to its targets, and the fit and unwrap
# errors over all subjects. Usage: bash scripts/demo/13_texture_dataset.sh <bin> <out>. Skipped when its output exists.
source "$(dirname "$0")/lib.sh"
data="$out/texture_data"
# Sizes (2 cores, 60 s for the section): renders 512² (fit at 256², the canonical face), inputs and targets 256²,
# high-res targets 1024² (the registered demo maps are 1024²). The paper's sizes are the defaults: renders and inputs
# 1024², targets 1024² and 4096² (bench/BENCHMARKS.md has their cost).
RENDER=${DEMO_TEXDATA_RENDER:-512}
RES=${DEMO_TEXDATA_RES:-256}
HR=${DEMO_TEXDATA_HR:-1024}
if [ ! -f "$data/test/manifest.json" ] || ! grep -q '"complete": true' "$data/test/manifest.json"; then
  echo "demo §13: texgen make-dataset (renders ${RENDER}², inputs/targets ${RES}², hr ${HR}²)" >&2
  timed "texture data" "$bareskin" -q texgen make-dataset "$out/registered" --model "$out/model/model.safetensors" \
    -o "$data" --render-size "$RENDER" --input-res "$RES" --target-res "$RES" --hr-res "$HR" --masks 3 --with-renders
fi

$py - "$data" "$out" "$RENDER" "$RES" "$HR" > "$out/sections/13_texture_dataset.html" <<'PY'
import glob, io, json, os, sys, tarfile
import numpy as np
from skimage import io as skio, transform
data, out, render, res, hr = sys.argv[1], sys.argv[2], *map(int, sys.argv[3:6])
img = os.path.join(out, "img")
manifest = json.load(open(f"{data}/test/manifest.json"))
with tarfile.open(f"{data}/test/{manifest['shards'][0]['name']}") as tar:
    members = {m.name.split(".", 1)[1]: tar.extractfile(m).read() for m in tar.getmembers()}
meta = json.loads(members["json"])
masks = json.load(open(f"{data}/masks/manifest.json"))
with tarfile.open(f"{data}/masks/{masks['shards'][0]['name']}") as tar:
    mask_png = next(tar.extractfile(m).read() for m in tar.getmembers() if m.name.endswith("mask.png"))

def tile(png, name, size=220):
    a = skio.imread(io.BytesIO(png))
    if a.dtype == np.uint16:
        a = (a / 257).astype(np.uint8)
    if a.ndim == 2:
        a = np.stack([a] * 3, -1)
    a = (transform.resize(a[..., :3], (size, size), anti_aliasing=True) * 255).astype(np.uint8)
    skio.imsave(os.path.join(img, f"texdata_{name}.png"), a, check_contrast=False)
    return f'<img src="img/texdata_{name}.png" style="width:{size}px">'

def fig(png, name, caption):
    return f"<figure>{tile(png, name)}<figcaption>{caption}</figcaption></figure>"

v = {x["name"]: x for x in meta["views"]}
renders = "".join(fig(members[f"render_{n}.png"], f"render_{n}", f"{n} (yaw {v[n]['yaw_deg']:+.0f}°): lit render, "
                      f"detector {v[n]['detector_error_px']:.1f} px off") for n in ("front", "left", "right"))
bare = "".join(fig(members[f"bare_{n}.png"], f"bare_{n}", f"{n}: diffuse only (unwrapped)") for n in ("front", "left", "right"))
inputs = (fig(members["unwrap.png"], "unwrap", f"merged unwrap ({meta['unwrap']['psnr_db_vs_truth']:.1f} dB vs truth)") +
          fig(members["confidence.png"], "confidence", f"confidence (coverage {100 * meta['unwrap']['coverage']:.0f}%)") +
          fig(members["mm_albedo.png"], "mm_albedo", "3DMM appearance Ā + B<sub>a</sub>δ") +
          fig(members["mm_normal.png"], "mm_normal", "3DMM normals (model frame)") +
          fig(members["mm_position.png"], "mm_position", "3DMM positions (mm, 16-bit)") +
          fig(mask_png, "mask", "a synthetic occlusion mask"))
targets = "".join(fig(members[f"{m}.png"], m, f"target {m} {res}²") for m in ("diffuse", "normal", "roughness", "specular"))
targets += fig(members["diffuse_hr.png"], "diffuse_hr", f"target diffuse {hr}² (downsized here)")

rows, agg = [], {}
for path in sorted(glob.glob(f"{data}/reports/*.json")):
    r = json.load(open(path))
    for light in r["lights"]:
        for x in light["views"]:
            a = agg.setdefault(x["name"], [])
            a.append((x["coverage"], x["detector_error_px"], x["landmark_rms_px"], x["shape_error_mm"]))
        agg.setdefault("merged", []).append((light["unwrap"]["coverage"], light["unwrap"]["psnr_db_vs_truth"]))
    agg.setdefault("seconds", []).append(r["seconds"]["total"])
for name in ("front", "left", "right"):
    m = np.mean(agg[name], 0)
    rows.append(f"<tr><td>{name}</td><td>{100 * m[0]:.1f}%</td><td>{m[1]:.1f}</td><td>{m[2]:.1f}</td><td>{m[3]:.2f}</td></tr>")
merged = np.mean(agg["merged"], 0)
counts = {s: json.load(open(f"{data}/{s}/manifest.json"))["samples"] for s in ("train", "val", "test")}
print(f"""<h2>13. Texture-inference data (texgen make-dataset)</h2>
<p>Each registered subject is rendered with its diffuse from the front and turned ±30°, under Deep3DFaceRecon's ambient
with a soft key light. On each render, as at inference, face-api finds the 68 landmarks (the detector's box, or the
face's pixels where its classifier rejects the render, then refinements), mm-fit fits pose, identity and expression
to them and appearance and light to the pixels; the diffuse-only render (what BareSkinNet hands texture inference) is
unwrapped through each view's own fit and the views are merged by confidence⁴. The fitted 3DMM's appearance, normals and
positions are baked into the same UV; the targets are the subject's four maps (uvtools bake). Sizes here: renders
{render}², inputs and targets {res}², high-res targets {hr}² (the registered demo maps are 1024²), so the section fits its
60 s; the defaults are the paper's (1K inputs, 1K and 4K targets). Shards: train {counts['train']}, val {counts['val']},
test {counts['test']} samples (split by subject), masks {masks['samples']}; mean {np.mean(agg['seconds']):.1f} s per
subject on 2 cores.</p>
<p>Sample <code>{meta['subject']}</code> (test split): the renders the fits saw, and the diffuse-only renders that were
unwrapped</p><div style="display:flex;flex-wrap:wrap;gap:6px">{renders}</div>
<div style="display:flex;flex-wrap:wrap;gap:6px">{bare}</div>
<p>Inputs (template UV)</p><div style="display:flex;flex-wrap:wrap;gap:6px">{inputs}</div>
<p>Targets</p><div style="display:flex;flex-wrap:wrap;gap:6px">{targets}</div>
<table><tr><th>view</th><th>coverage</th><th>detector vs truth (px at {render}²)</th><th>landmark fit RMS (px)</th>
<th>fitted shape vs scan (mm)</th></tr>{''.join(rows)}</table>
<p>Merged over all subjects: coverage {100 * merged[0]:.1f}%, unwrap PSNR {merged[1]:.1f} dB against the truth
diffuse over the seen texels. The errors the texture network must undo come from the landmarks: the detector is
{np.mean([a[1] for k in ('front', 'left', 'right') for a in agg[k]]):.1f} px off on these synthetic renders, which
shifts the fitted geometry by millimetres and the unwrap with it.</p>""")
PY
