#!/usr/bin/env bash
# BareSkinNet's speed against accuracy over G's width: one two-stage `train bareskin` run per ngf (16 / 32 / 64) with
# the Fig. 7 ablation's full recipe (row g: 64², 120 + 40 steps, lr 2e-4, seed 0), each scored on its held-out test
# split (<run>/eval.json: PSNR vs the bare truth on skin, G's ms per image at the training size). Prints the table and
# charts PSNR against ms (bareskinnet_width.png next to this script's output). Runs whose eval.json exists are kept.
#   bash bench/bareskinnet_width.sh <bin> <faces/> <teacher run> <model.safetensors> <out/>
set -euo pipefail
bin=$1 faces=$2 teacher=$3 model=$4 out=$5
mkdir -p "$out"
for ngf in 16 32 64; do
  [ -f "$out/ngf$ngf/eval.json" ] && continue
  echo "width: ngf $ngf" >&2
  nice "$bin/bareskin" -q --threads 2 train bareskin --data "$faces" -o "$out/ngf$ngf" --resume --size 64 \
    --g-options "{\"ngf\": $ngf}" --d-options '{"ndf": 16}' --student-options '{"width": 16}' --steps1 120 \
    --steps2 40 --teacher "$teacher" --model "$model" --lr-g 2e-4 --lr-d 2e-4 --seed 0 --log-every 20 \
    --checkpoint-every 120 --eval-every 0 --sample-every 0 --eval-samples 50
done
/usr/bin/python3 - "$out" <<'PY'
import json, os, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
out = sys.argv[1]
rows = []
for ngf in (16, 32, 64):
    j = json.load(open(os.path.join(out, f"ngf{ngf}", "eval.json")))
    rows.append((ngf, j["mean"]["psnr_bare"], j["mean"]["ssim_bare"], j["ms_per_image"], j["mean"]["psnr_input_bare"]))
best = max(r[1] for r in rows)
pick = min(r[0] for r in rows if r[1] >= best - 0.5)
print("| ngf | PSNR vs bare | SSIM vs bare | G ms per 64² image | within 0.5 dB of the best |")
print("|---|---|---|---|---|")
for ngf, psnr, ssim, ms, _ in rows:
    print(f"| {ngf} | {psnr:.2f} dB | {ssim:.3f} | {ms:.1f} | {'yes' if psnr >= best - 0.5 else 'no'}{' (default)' if ngf == pick else ''} |")
print(f"the unchanged input: {rows[0][4]:.2f} dB; smallest within 0.5 dB of the best: ngf {pick}")
fig, ax = plt.subplots(figsize=(5, 3.2), dpi=120)
ax.plot([r[3] for r in rows], [r[1] for r in rows], "o-", color="tab:blue", label="G (held-out test split)")
for ngf, psnr, _, ms, _ in rows:
    ax.annotate(f"ngf {ngf}", (ms, psnr), textcoords="offset points", xytext=(4, 4), fontsize=8)
ax.axhline(rows[0][4], color="grey", ls="--", lw=1, label="input unchanged")
ax.set_xscale("log")
ax.minorticks_off()
ax.set_xticks([r[3] for r in rows])
ax.set_xticklabels([f"{r[3]:.1f}" for r in rows])
ax.set_xlabel("G ms per 64² image (CPU, 2 threads)")
ax.set_ylabel("PSNR vs bare truth on skin (dB)")
ax.set_title("BareSkinNet G width: speed vs accuracy (64², 120 + 40 steps)", fontsize=9)
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(os.path.join(out, "bareskinnet_width.png"))
PY
