#!/usr/bin/env bash
# Demo §11: the reconstruction network F — a small F trained on the demo's face shards (bareskin train recon), then
# held-out faces of new identities (yaw up to 60°) against their truth and against mm-fit's landmark fitter
# (bareskin recon --eval), and a real photo through detect → align → F → mm-fit refinement (bareskin recon).
# Usage: bash scripts/demo/11_recon.sh <bin> <out>. Stages whose outputs exist are skipped.
source "$(dirname "$0")/lib.sh"
dir="$out/recon"
mkdir -p "$dir"
model="$out/model/model.safetensors"
# Sizes (2 cores, 150 s for the section): `--profile cpu` (docs/training.md, "Profiles"): F is a ResNet-18 of width 16
# (the paper's F: ResNet-50, width 64) trained at 128² (the samples are 256²; the canonical camera scales with the
# size), supervised by the samples' coefficients and Deep3DFaceRecon's landmark, regularisation and light terms (the
# photometric and identity terms render every face and cost ~4x a step on the CPU), here for 300 steps of 8 instead of
# the profile's 3000. Held-out: 40 new 3DMM identities.
STEPS=${DEMO_RECON_STEPS:-300}
SIZE=${DEMO_RECON_SIZE:-128}
faces="$out/faces"
if [ ! -f "$faces/train/manifest.json" ]; then
  faces="$dir/faces"
  if [ ! -f "$faces/train/manifest.json" ]; then
    echo "demo §11: texgen faces (120 training faces; the faces section was not run)" >&2
    timed "recon faces" "$bareskin" -q texgen faces --registered "$out/registered" --model "$model" --count 120 \
      --seed 1 --styles none --val 0 --test 0 -o "$faces"
  fi
fi
if [ ! -f "$dir/heldout/train/manifest.json" ]; then
  echo "demo §11: 40 held-out faces of new identities, yaw up to 60°" >&2
  timed "recon heldout" "$bareskin" -q texgen faces --model "$model" --count 40 --seed 1011 --mm-subjects 40 \
    --val 0 --test 0 --yaw-max 60 --expression-prob 0.6 --styles none -o "$dir/heldout"
fi
if [ ! -f "$dir/F/checkpoint.safetensors" ]; then
  echo "demo §11: bareskin train recon (resnet18 width 16 at ${SIZE}², $STEPS steps)" >&2
  timed "recon train" "$bareskin" -q train recon --profile cpu --image-size "$SIZE" --data "$faces" --model "$model" \
    -o "$dir/F" --steps "$STEPS" --log-every 25 --eval-every 0 --sample-every "$STEPS" --checkpoint-every "$STEPS"
fi
if [ ! -f "$dir/eval/metrics.json" ]; then
  echo "demo §11: bareskin recon --eval on the held-out faces" >&2
  timed "recon eval" "$bareskin" -q recon --eval "$dir/heldout/train" --run "$dir/F" -o "$dir/eval"
fi
photo=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
if [ -f "$photo" ] && [ ! -f "$dir/astronaut/overlay.png" ]; then
  timed "recon photo" "$bareskin" -q recon "$photo" --run "$dir/F" --refine -o "$dir/astronaut"
fi

$py - "$dir" "$out" "$STEPS" "$SIZE" > "$out/sections/11_recon.html" <<'PY'
import json, shutil, sys
d, out, steps, size = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
m = json.load(open(f"{d}/eval/metrics.json"))
for name in ("speed_accuracy.svg", "failure_yaw.svg", "failure_expression.svg"):
    shutil.copy(f"{d}/eval/{name}", f"{out}/img/recon_{name}")
shutil.copy(f"{d}/eval/img/heat_maps.png", f"{out}/img/recon_heat_maps.png")
try:
    shutil.copy(f"{d}/astronaut/overlay.png", f"{out}/img/recon_astronaut.png")
    astro = json.load(open(f"{d}/astronaut/coefficients.json"))
except FileNotFoundError:
    astro = None
f = lambda x, n=2: "n/a" if x is None or x != x else f"{x:.{n}f}"
s, c = m["shape_mm"], m["confidence"]
rows = [("shape error, mm (per vertex, median / p95)", f"{f(s['median_per_vertex'])} / {f(s['p95_per_vertex'])}"),
        ("… after similarity alignment", f"{f(m['shape_aligned_mm']['median_per_vertex'])} / {f(m['shape_aligned_mm']['p95_per_vertex'])}"),
        ("shape error per face, median (the mean face: no fit)", f"{f(s['median_per_face'])} ({f(s['mean_face_median_per_face'])})"),
        (f"landmark RMS, px at {m['image_size']}²", f(m["landmark_px"]["median"])),
        ("skin PSNR, dB (linear light)", f(m["skin_psnr_db"]["median"])),
        ("γ RMS error", f(m["gamma_rmse"]["median"], 3)),
        ("α / β / δ RMS error, σ", f"{f(m['alpha_sigma'])} / {f(m['beta_sigma'])} / {f(m['delta_sigma'])}"),
        ("rotation error, degrees", f(m["rotation_deg"])),
        ("identity cosine (face-api, overlay vs input)", f(m["identity_cosine"], 3)),
        ("forward pass, ms (CPU)", f(m["net_ms"]["median"], 1)),
        (f"confidence: flags of answers > {c['bad_mm']} mm ({c['bad']} of {m['faces']})",
         f"{f(100 * c['flag_detection_rate'] if c['bad'] else None, 0)}% caught, {f(100 * c['flag_false_alarm_rate'], 0)}% false alarms; "
         f"best at ≤ 10% false alarms: {f(100 * c['detection_rate_at_10pct_false_alarms'] if c['bad'] else None, 0)}%")]
table = "".join(f"<tr><td>{a}</td><td>{b}</td></tr>" for a, b in rows)
speed = "".join(f"<tr><td>{r['iterations']}</td><td>{f(r['mmfit_ms'])}</td><td>{f(r['mmfit_mm'])}</td>"
                f"<td>{f(r['refine_ms'])}</td><td>{f(r['refine_mm'])}</td><td>{f(r['truth_landmarks_mm'])}</td></tr>"
                for r in m["speed"])
print(f"""<h2>11. Face reconstruction by network: the teacher F</h2>
<p><code>bareskin train recon</code> trained a small F (ResNet-18, width 16, at {size}², {steps} steps of 8 on the
demo's face shards; the paper's F is a ResNet-50 at 224²) to regress α, β, δ, the pose and the SH light γ from an aligned
face. <code>bareskin recon --eval</code> ran it on {m['faces']} held-out faces of identities it never saw (yaw up to 60°,
expressions), against their true coefficients, and ran mm-fit's landmark fitter on the same faces from the detector's
landmarks. Sizes are the demo's (2 cores, ~150 s): at this size F learns the pose and the light roughly (rotation
error {f(m['rotation_deg'], 1)}°) but not yet the identity — compare its shape error with the mean face's. bench/BENCHMARKS.md has the figures and how to reproduce them at larger sizes.</p>
<table>{table}</table>
<figure><img src="img/recon_heat_maps.png" style="width:540px"><figcaption>Held-out faces: the input | F's answer
rendered over it | per-vertex shape error on F's face (blue 0 mm → red ≥ 5 mm).</figcaption></figure>
<figure><img src="img/recon_speed_accuracy.svg" style="width:560px"><figcaption>Speed against accuracy (median over
faces): mm-fit's Levenberg–Marquardt from the mean face after 1–40 iterations, F's single forward pass, mm-fit
started from F's answer, and mm-fit on the true landmarks (a bound no photo gives). mm-fit needs the detector's
landmarks: face-api found {m['detected']} of the {m['faces']} rendered faces (the medians of the detector curves are
over those); its landmark convention differs from the model's landmark vertices.</figcaption></figure>
<table><tr><th>iterations</th><th>mm-fit ms</th><th>mm-fit mm</th><th>F + mm-fit ms</th><th>F + mm-fit mm</th>
<th>mm-fit on true landmarks, mm</th></tr>{speed}</table>
<figure><img src="img/recon_failure_yaw.svg" style="width:480px"><img src="img/recon_failure_expression.svg"
style="width:480px"><figcaption>Where it fails: shape error and landmark RMS against |yaw| and expression strength.
</figcaption></figure>""")
if astro:
    print(f"""<figure><img src="img/recon_astronaut.png" style="width:300px"><figcaption>A real photo
(skimage's astronaut): face-api → 5-point alignment → F → <code>--refine</code> (mm-fit from F's answer). F's own answer:
confidence {f(astro['confidence'], 3)} (landmarks {f(astro['landmark_residual_px'], 1)} px from the detector's, skin
PSNR {f(astro['psnr_db'], 1)} dB){' — flagged' if astro['flagged'] else ''}.</figcaption></figure>""")
PY
