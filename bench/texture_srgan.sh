#!/usr/bin/env bash
# SRGAN x4 vs bicubic on held-out diffuse maps (the subjects of the val and test splits together): the true map
# box-filtered x4 down, then up again, PSNR against the truth over the whole map. Rows: bicubic; BasicSR's recipe
# (bilinear base, L1 pre-training); ours (bicubic base that starts at bicubic, MSE pre-training); ours + the GAN phase.
# All at the demo's sizes (MSRResNet 16 features x 4 blocks, 128² crops of batch 2, Adam 2e-3) and length.
# Usage: bash bench/texture_srgan.sh <bin> <texture shards: folder with train/ val/ test/> <model> <work dir>
#        [pre-training steps (300)] [GAN steps (60)]
set -euo pipefail
bin=${1:-build/bin}; data=${2:-out/demo/texture_data}; model=${3:-out/demo/model/model.safetensors}
work=${4:-out/bench_srgan}; steps=${5:-300}; gan_steps=${6:-60}
py=/usr/bin/python3
export OMP_WAIT_POLICY=PASSIVE
mkdir -p "$work"
# One held-out shard set: the val and test splits' shards (hard links) under one manifest.
heldout="$work/heldout"
if [ ! -f "$heldout/manifest.json" ]; then
  mkdir -p "$heldout"
  $py - "$data" "$heldout" <<'PY'
import json, os, sys
data, out = sys.argv[1:3]
merged = None
for split in ("val", "test"):
    m = json.load(open(os.path.join(data, split, "manifest.json")))
    for s in m["shards"]:
        name = f"{split}-{s['name']}"
        if not os.path.exists(os.path.join(out, name)):
            os.link(os.path.join(data, split, s["name"]), os.path.join(out, name))
        s["name"] = name
    if merged is None:
        merged = m
    else:
        merged["shards"] += m["shards"]
        merged["samples"] += m["samples"]
merged["metadata"]["split"] = "heldout"
json.dump(merged, open(os.path.join(out, "manifest.json"), "w"), indent=1)
PY
fi
gen='{"num_feat": 16, "num_block": 4}'
common=(--map diffuse --data "$data/train" --val "$heldout" --model "$model" --batch 2 --patch 128 --generator "$gen"
        --log-every 50 --sample-every 100000)
train() {  # name, then flags
  local name=$1 start=$EPOCHREALTIME
  shift
  [ -f "$work/$name/checkpoint.safetensors" ] || "$bin/bareskin" -q --threads 2 train upscale "${common[@]}" \
    -o "$work/$name" "$@"
  $py -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$EPOCHREALTIME" \
    > "$work/$name.seconds"
}
train basicsr --phase l1 --pixel-loss l1 --base bilinear --lr 2e-3 --steps "$steps" --eval-every "$steps" \
  --checkpoint-every "$steps"
train ours --phase l1 --lr 2e-3 --steps "$steps" --eval-every "$steps" --checkpoint-every "$steps"
train ours_gan --phase gan --init "$work/ours" --discriminator '{"num_feat": 16}' --lambda-perceptual 0 \
  --lr 1e-4 --steps "$gan_steps" --eval-every "$gan_steps" --checkpoint-every "$gan_steps"
$py - "$work" "$steps" "$gan_steps" <<'PY'
import csv, os, sys
work, steps, gan_steps = sys.argv[1:4]
def last(run):
    rows = list(csv.DictReader(open(os.path.join(work, run, "eval.csv"))))
    step = max(int(r["step"]) for r in rows)
    return {r["name"]: float(r["value"]) for r in rows if int(r["step"]) == step}
base = last("ours")["psnr_bicubic"]
print(f"SRGAN x4 on the held-out diffuse (val + test subjects), PSNR vs the true map (dB):")
print(f"{'method':52s} {'PSNR':>7s} {'vs bicubic':>10s} {'train s':>8s}")
print(f"{'bicubic':52s} {base:7.2f} {0:10.2f} {'-':>8s}")
for run, label in (("basicsr", f"BasicSR recipe: bilinear base, L1, {steps} steps"),
                   ("ours", f"ours: bicubic base from bicubic, MSE, {steps} steps"),
                   ("ours_gan", f"ours + GAN phase ({gan_steps} steps)")):
    v = last(run)["psnr_srgan"]
    secs = open(os.path.join(work, run + ".seconds")).read().strip()
    print(f"{label:52s} {v:7.2f} {v - base:+10.2f} {secs:>8s}")
PY
