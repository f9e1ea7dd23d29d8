#!/usr/bin/env bash
# The reconstruction network F against mm-fit on the same held-out faces, and F's CPU latency at the paper's size.
# Usage: bash bench/recon_bench.sh [bin] [demo out]   (after scripts/demo/11_recon.sh, which trains F and writes the
# held-out faces; default build/bin out/demo). Prints ours vs the anchor side by side.
set -euo pipefail
bin=${1:-build/bin}
out=${2:-out/demo}
dir="$out/recon"
bareskin="$bin/bareskin"
py=/usr/bin/python3
[ -f "$dir/F/checkpoint.safetensors" ] || { echo "run scripts/demo/11_recon.sh $bin $out first" >&2; exit 2; }
faces="$out/faces"
[ -f "$faces/train/manifest.json" ] || faces="$dir/faces"
[ -f "$dir/eval/metrics.json" ] || "$bareskin" -q recon --eval "$dir/heldout/train" --run "$dir/F" -o "$dir/eval"

# Latency of the paper's F (ResNet-50, width 64) at 224² and 256², batch 1, on this machine's threads: a one-step run
# gives the net (its weights do not matter for the time), --eval times its forward pass over 8 faces.
for size in 224 256; do
  run="$dir/bench_resnet50_$size"
  [ -f "$run/checkpoint.safetensors" ] || "$bareskin" -q train recon --arch resnet50 --gamma on --image-size "$size" \
    --supervision truth --data "$faces" --model "$out/model/model.safetensors" -o "$run" --steps 1 --batch 2 \
    --eval-every 0 --sample-every 0 --checkpoint-every 1
  [ -f "$run/eval/metrics.json" ] || "$bareskin" -q recon --eval "$dir/heldout/train" --run "$run" -o "$run/eval" \
    --eval-faces 8
done

$py - "$dir" <<'PY'
import json, sys
d = sys.argv[1]
m = json.load(open(f"{d}/eval/metrics.json"))
f = lambda x, n=2: "n/a" if x is None or x != x else f"{x:.{n}f}"
print(f"held-out faces: {m['faces']} ({d}/heldout), F: {d}/F at {m['image_size']}²")
print(f"{'method':44s} {'ms/face':>9s} {'shape mm (median/face)':>24s}")
print(f"{'the mean face (no fit)':44s} {'0':>9s} {f(m['shape_mm']['mean_face_median_per_face']):>24s}")
print(f"{'ours: F, one forward pass':44s} {f(m['net_ms']['median'], 1):>9s} {f(m['shape_mm']['median_per_face']):>24s}")
for r in m["speed"]:
    print(f"{'anchor: mm-fit landmark fit, ' + str(r['iterations']) + ' iterations':44s} {f(r['mmfit_ms'], 1):>9s} {f(r['mmfit_mm']):>24s}"
          f"   | F + mm-fit: {f(r['refine_ms'], 1)} ms, {f(r['refine_mm'])} mm")
s, c = m["shape_mm"], m["confidence"]
print(f"F: shape per vertex median {f(s['median_per_vertex'])} / p95 {f(s['p95_per_vertex'])} mm "
      f"(aligned {f(m['shape_aligned_mm']['median_per_vertex'])} / {f(m['shape_aligned_mm']['p95_per_vertex'])}), "
      f"landmarks {f(m['landmark_px']['median'])} px, skin PSNR {f(m['skin_psnr_db']['median'])} dB, "
      f"gamma RMS {f(m['gamma_rmse']['median'], 3)}, alpha/beta/delta {f(m['alpha_sigma'])}/{f(m['beta_sigma'])}/"
      f"{f(m['delta_sigma'])} sigma, identity cos {f(m['identity_cosine'], 3)}")
print(f"confidence vs shape > {c['bad_mm']} mm: {c['bad']} bad of {m['faces']}; flags catch "
      f"{f(c['flag_detection_rate'], 2)} with {f(c['flag_false_alarm_rate'], 2)} false alarms; best catch at <= 10% "
      f"false alarms {f(c['detection_rate_at_10pct_false_alarms'], 2)}")
print("by |yaw|:", ", ".join(f"{r['from']:.0f}-{r['to']:.0f} deg: {f(r['shape_mm'])} mm, {f(r['landmark_px'], 1)} px ({r['faces']})" for r in m["by_yaw"]))
for size in (224, 256):
    b = json.load(open(f"{d}/bench_resnet50_{size}/eval/metrics.json"))
    print(f"ResNet-50 F (25.6 M parameters + heads) at {size}^2, batch 1, CPU: {f(b['net_ms']['median'], 1)} ms median forward")
PY
