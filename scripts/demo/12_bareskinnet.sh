#!/usr/bin/env bash
# Demo §12: BareSkinNet — `bareskin train bareskin` (stage 1: G + PatchGAN + LPIPS; stage 2: G through the 3DMM render
# of the frozen teacher F's fit) on the demo's face samples (§10) with the demo's F (§11), its
# held-out evaluation (test split: unseen subjects and makeup styles), and `bareskin demakeup` on skimage's astronaut.
# Usage: bash scripts/demo/12_bareskinnet.sh <bin> <out>. Stages whose outputs exist are skipped.
source "$(dirname "$0")/lib.sh"
dir="$out/bareskinnet"
mkdir -p "$dir"
# Sizes (2 cores, ≈ 3 min for both stages, the evaluation and the photo): `--profile cpu` (docs/training.md,
# "Profiles": G a U-Net of width 16 with the affine head at 128², the 256² samples area-resized; PatchGAN ndf 16 with 2
# layers; stage 2 through F itself at L_diff (up to a gain) and L_light 20; half the samples' makeup painted over in
# colours of any hue; batch 8; LPIPS on face-api's recognition
# net; G and D at pix2pix's 2e-4; the bare albedo as G's target; the moving average of G's weights for evaluation
# and inference), shortened to STEPS1 + STEPS2 steps (the profile: 1500 + 300; the paper: 10k + 30k at 256², ngf 64).
STEPS1=${DEMO_BSN_STEPS1:-300}
STEPS2=${DEMO_BSN_STEPS2:-60}
faces=${DEMO_BSN_FACES:-$out/faces}
model="$out/model/model.safetensors"
# The teacher F: the first recon run under <out> whose checkpoint holds F (§11 writes it).
teacher=${DEMO_BSN_TEACHER:-$($py - "$out" <<'PY'
import json, os, struct, sys
for root, dirs, files in sorted(os.walk(sys.argv[1])):
    if "checkpoint.safetensors" not in files:
        continue
    path = os.path.join(root, "checkpoint.safetensors")
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
    meta = json.loads(header.get("__metadata__", {}).get("bareskin.checkpoint", "{}"))
    if meta.get("task") == "recon" and any(k.startswith("module.F.") for k in header):
        print(root)
        break
PY
)}
[ -f "$faces/train/manifest.json" ] || { echo "demo §12: no face samples in $faces (demo §10 makes them)" >&2; exit 1; }
run="$dir/run"
stage2=(--steps2 "$STEPS2" --teacher "$teacher" --model "$model")
if [ -z "$teacher" ]; then
  echo "demo §12: no teacher F under $out (demo §11): stage 1 only" >&2
  stage2=(--steps2 0)
fi
if [ ! -f "$run/eval.json" ]; then
  echo "demo §12: train bareskin (--profile cpu, $STEPS1 + $STEPS2 steps)" >&2
  resume=()
  [ -f "$run/stage1/checkpoint.safetensors" ] && resume=(--resume)
  timed "bareskinnet" "$bareskin" -q train bareskin --profile cpu --data "$faces" -o "$run" "${resume[@]}" \
    --steps1 "$STEPS1" "${stage2[@]}" --log-every 10 --checkpoint-every 60 --eval-every 0 --sample-every 60 \
    --eval-samples 48
fi
if [ "${DEMO_BSN_ABLATION:-0}" = 1 ] && [ -n "$teacher" ] && [ ! -f "$dir/ablation.md" ]; then
  timed "bsn ablation" bash "$(dirname "$0")/../../bench/bareskinnet_ablation.sh" "$bin" "$faces" "$teacher" "$model" \
    "$dir/ablation" 64 120 40 0,1 > "$dir/ablation.md.tmp"
  mv "$dir/ablation.md.tmp" "$dir/ablation.md"
fi
photo=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
if [ -n "$teacher" ] && [ -f "$photo" ] && [ ! -f "$dir/astronaut/coefficients.json" ]; then
  timed "demakeup" "$bareskin" -q demakeup "$photo" --run "$run" -o "$dir/astronaut" --uv-size 512
fi

$py - "$dir" "$out" "$STEPS1" "$STEPS2" "${teacher:-none}" > "$out/sections/12_bareskinnet.html" <<'PY'
import glob, json, os, shutil, sys
import numpy as np
from skimage import io as skio
d, out, steps1, steps2, teacher = sys.argv[1], sys.argv[2], *map(int, sys.argv[3:5]), sys.argv[5]
task = json.load(open(os.path.join(d, "run", "stage1", "config.json")))["task"]
size, ngf, lr, target, ema = task["size"], task["g"].get("ngf", 64), task["lr_g"], task["target"], task["ema"]
t2 = os.path.join(d, "run", "stage2", "config.json")
t2 = json.load(open(t2))["task"] if os.path.exists(t2) else task
through = ("the student E, a ResNet-18 of width 16, taught by F" if t2["recon"] == "E" else
           "F itself, gradients through it (<code>--recon F</code>; the paper trains a student E)")
stage2 = (("+ %g·L<sub>coeff</sub> + " % t2["w_coeff"] if t2["recon"] == "E" else "+ ") +
          f"{t2['w_land']:g}·L<sub>land</sub> + {t2['w_diff']:g}·L<sub>diff</sub> + {t2['w_light']:g}·L<sub>light</sub> "
          f"+ {t2['w_reg']:g}·L<sub>reg</sub> through the 3DMM render of {through}; teacher F: {teacher}" +
          ("; L<sub>diff</sub> up to a gain per image and channel on the render's albedo (<code>--diff-gain</code>, "
           "ours: the 3DMM's albedos need not span every skin tone)" if t2.get("diff_gain") else ""))
img = os.path.join(out, "img")
run = os.path.join(d, "run")
ev = json.load(open(os.path.join(run, "eval.json")))
print("<h2>12. BareSkinNet: de-makeup and de-lighting</h2>")
print(f"<p><code>bareskin train bareskin --profile cpu</code>: G (pix2pix U-Net, {task['head']} head) at {size}² with "
      f"ngf {ngf}, PatchGAN ndf {task['d'].get('ndf', 64)}, batch 8, stage 1 (L<sub>DD</sub> = 100·L1 + GAN + 40·LPIPS, "
      f"{task['lpips_trunk']} trunk) for {steps1} steps (the profile: 1500), "
      f"then stage 2 ({stage2}) for "
      f"{steps2} steps (the profile: 300), G and D at learning rate {lr} (pix2pix's; the paper's 2e-5 suits its 40k "
      "steps). G outputs its input times a gain plus an offset per pixel, both starting at the identity (ours, not the "
      "paper's: step 0 is the unchanged input, so the table below shows what training adds). " +
      ("G's target is the bare albedo truth on the face region and the input elsewhere (<code>--target bare</code>, "
       "ours: our world has the truth the paper lacked; the paper's <code>--target before</code>, the lit image "
       "without makeup, leaves the de-lighting to stage 2 alone and scored 1.7 dB lower against the bare truth at "
       "these sizes, bench/BENCHMARKS.md). " if target == "bare" else
       "G's target is the before image (the paper's: lit, no makeup). ") +
      (f"A share of {task['makeup_paint']:g} of the training samples has its makeup painted over in opaque colours "
       "of any hue, lit by the photo's light (<code>--makeup-paint</code>, ours: the held-out family's colours lie "
       "outside the world's palettes). " if task.get("makeup_paint") else "") +
      (f"Evaluation, grids and <code>demakeup</code> use the moving average of G's weights (<code>--ema-g {ema}</code>, "
       "ours: steadier across makeup and light at these steps, bench/BENCHMARKS.md). " if float(ema) > 0 else "") +
      "The paper trains 10k + 30k steps at 256² with ngf 64 on a GPU; the demo trains the CPU profile for a fifth "
      "of its steps to fit 2 cores and about 3 minutes (bench/cpu_reference.sh trains it whole).</p>")
figs = []
for stage in ("stage1", "stage2"):
    svg = os.path.join(run, stage, "losses.svg")
    if os.path.exists(svg):
        shutil.copy(svg, os.path.join(img, f"bsn_{stage}_losses.svg"))
        figs.append(f'<figure><img src="img/bsn_{stage}_losses.svg" style="width:420px"><figcaption>{stage} losses '
                    "(weighted)</figcaption></figure>")
print("<div>" + "".join(figs) + "</div>")
for stage in ("stage1", "stage2"):
    grids = sorted(glob.glob(os.path.join(run, stage, "samples", "*.png")))
    if grids:
        a = skio.imread(grids[-1])
        skio.imsave(os.path.join(img, f"bsn_{stage}_samples.png"), a, check_contrast=False)
        print(f'<figure><img src="img/bsn_{stage}_samples.png" style="width:{min(4 * 200, a.shape[1] * 2)}px">'
              f"<figcaption>{stage}, last step, held-out (val) subjects: makeup input | G | " +
              ("G's target (the bare albedo truth on the face, the input elsewhere)" if target == "bare" else
               "before (G's target) | bare albedo truth") + "</figcaption></figure>")
m = ev["mean"]
def row(name, key):
    cells = []
    for truth in ("bare", "before"):
        for metric, fmt in (("psnr", "{:.2f} dB"), ("ssim", "{:.4f}"), ("lpips", "{:.4f}")):
            k = f"{metric}_{key}{truth}"
            cells.append(fmt.format(m[k]) if k in m else "—")
    ident = m.get(f"identity_{key}bare")
    cells.append(f"{ident:.3f}" if ident is not None else "—")
    return f"<tr><td>{name}</td>" + "".join(f"<td>{c}</td>" for c in cells) + "</tr>"
print(f"<p>Held-out test split ({ev['samples']} faces: subjects never trained on, and the makeup styles "
      "texgen kept out of training), skin region, at G's resolution; LPIPS trunk " + ev.get("lpips_trunk", "") +
      "; identity: cosine of face-api descriptors against the bare truth.</p>")
print("<table><tr><th></th><th>PSNR vs bare</th><th>SSIM vs bare</th><th>LPIPS vs bare</th><th>PSNR vs before</th>"
      "<th>SSIM vs before</th><th>LPIPS vs before</th><th>identity</th></tr>")
print(row("G's output", "") + row("the input (do nothing)", "input_"))
print("</table>")
mean = ev["mean"]
regions = [("skin (the table above)", "psnr_bare", "psnr_input_bare"), ("the whole face", "psnr_face_bare", "psnr_face_input_bare"),
           ("where the makeup is", "psnr_makeup_bare", "psnr_makeup_input_bare"),
           ("F's unlit albedo of it", "psnr_albedo_bare", "psnr_albedo_input_bare")]
print("<table><tr><th>region, PSNR vs bare</th><th>G's output</th><th>the input</th><th>gain</th></tr>")
for name, g, i in regions:
    if g in mean and i in mean:
        print(f"<tr><td>{name}</td><td>{mean[g]:.2f} dB</td><td>{mean[i]:.2f} dB</td><td>{mean[g] - mean[i]:+.2f} dB</td></tr>")
print("</table>")
styles = {k: v for k, v in ev["by_style"].items() if k != "count"}
if styles:
    print("<table><tr><th>style (test)</th><th>faces</th><th>G PSNR vs bare</th><th>input PSNR vs bare</th></tr>")
    for s, v in sorted(styles.items()):
        print(f"<tr><td>{s}</td><td>{int(ev['by_style']['count'].get(s, 0))}</td><td>{v['psnr_bare']:.2f}</td>"
              f"<td>{v['psnr_input_bare']:.2f}</td></tr>")
    print("</table>")
print(f"<p>G alone: {ev['ms_per_image']:.1f} ms per {size}² image on this CPU.</p>")
a = os.path.join(d, "astronaut")
if os.path.exists(os.path.join(a, "coefficients.json")):
    tiles = []
    for name, cap in (("aligned", "aligned input"), ("bare", "G: bare skin"), ("unlit", "F's fit, unlit 3DMM"),
                      ("uv", "bare skin in the UV (512²)")):
        x = skio.imread(os.path.join(a, f"{name}.png"))
        skio.imsave(os.path.join(img, f"bsn_astronaut_{name}.png"), x, check_contrast=False)
        tiles.append(f'<figure><img src="img/bsn_astronaut_{name}.png" style="width:220px"><figcaption>{cap}'
                     "</figcaption></figure>")
    print("<p><code>bareskin demakeup astronaut.png</code> (skimage's photo: a real face, no truth):</p><div>" +
          "".join(tiles) + "</div>")
abl = os.path.join(d, "ablation.md")
if os.path.exists(abl):
    rows = [l.strip().strip("|").split("|") for l in open(abl) if l.startswith("|") and not l.startswith("|---")]
    print(f"<p>The paper's Fig. 7 ablation with the profile's nets (<code>bench/bareskinnet_ablation.sh</code>, "
          f"{size}², 120 + 40 steps, two seeds per row; ± is the 95% interval over the seeds, and a row's step "
          "holds when the interval of its paired differences excludes 0):</p><table>")
    for i, r in enumerate(rows):
        tag = "th" if i == 0 else "td"
        print("<tr>" + "".join(f"<{tag}>{c.strip()}</{tag}>" for c in r) + "</tr>")
    print("</table>")
else:
    print("<p>The ablation of the paper's Fig. 7 (<code>--ablation b…g</code>, six rows × two seeds) does not fit this "
          "section's budget: <code>DEMO_BSN_ABLATION=1</code> runs it here; bench/BENCHMARKS.md, \"BareSkinNet\", "
          "has the measured table (three seeds).</p>")
PY
echo "demo §12: wrote $out/sections/12_bareskinnet.html" >&2
