#!/usr/bin/env bash
# The paper's Fig. 7 ablation as a table at demo size: one two-stage `train bareskin` run per row (b..g) on the same
# face shards, teacher F and sizes, each scored by its own held-out evaluation (<run>/eval.json: the test split,
# subjects and makeup styles never trained on), plus row (g) again with another seed: the run-to-run noise that a
# difference between rows must exceed. Usage:
#   bash bench/bareskinnet_ablation.sh <bin> <faces/> <teacher run> <model.safetensors> <out/> [size] [steps1] [steps2] \
#     [target] [ema]
# target: G's supervision, before (the paper's, the default) or bare (ours: the albedo truth on the face region);
# ema: --ema-g's decay (0, the default: off).
# Prints a Markdown table (PSNR/SSIM vs bare and vs before on skin) with the unchanged input as the baseline row.
# G is ours (input + Δ, starting as the identity; docs/training.md) at learning rate 2e-4.
set -euo pipefail
bin=$1 faces=$2 teacher=$3 model=$4 out=$5
size=${6:-64} steps1=${7:-120} steps2=${8:-40} target=${9:-before} ema=${10:-0}
mkdir -p "$out"
for run in b c d e f g g_seed1; do
  [ -f "$out/$run/eval.json" ] && continue
  row=${run%%_*} seed=0
  [ "$run" = g_seed1 ] && seed=1
  echo "ablation $run: ${size}², $steps1 + $steps2 steps, seed $seed, target $target, ema $ema" >&2
  nice "$bin/bareskin" -q --threads 2 train bareskin --data "$faces" -o "$out/$run" --resume --size "$size" \
    --g-options '{"ngf": 16}' --d-options '{"ndf": 16}' --student-options '{"width": 16}' --ablation "$row" \
    --steps1 "$steps1" --steps2 "$steps2" --teacher "$teacher" --model "$model" --lr-g 2e-4 --lr-d 2e-4 --seed "$seed" \
    --target "$target" --ema-g "$ema" \
    --log-every 20 --checkpoint-every "$steps1" --eval-every 0 --sample-every 0 --eval-samples 50
done
/usr/bin/python3 - "$out" <<'PY'
import json, os, sys
out = sys.argv[1]
names = {"b": "L1 + GAN", "c": "+ LPIPS", "d": "+ frozen F", "e": "+ fine-tuned F", "f": "+ E, no L_light", "g": "full",
         "g_seed1": "full, seed 1 (noise)"}
print("| row | losses | PSNR vs bare | SSIM vs bare | PSNR vs before | SSIM vs before |")
print("|---|---|---|---|---|---|")
for run in ["b", "c", "d", "e", "f", "g", "g_seed1"]:
    m = json.load(open(os.path.join(out, run, "eval.json")))["mean"]
    if run == "b":
        print(f"| — | the input unchanged | {m['psnr_input_bare']:.2f} dB | {m['ssim_input_bare']:.3f} | "
              f"{m['psnr_input_before']:.2f} dB | {m['ssim_input_before']:.3f} |")
    print(f"| ({run[0]}) | {names[run]} | {m['psnr_bare']:.2f} dB | {m['ssim_bare']:.3f} | {m['psnr_before']:.2f} dB | "
          f"{m['ssim_before']:.3f} |")
PY
