#!/usr/bin/env bash
# SRGAN x4 vs bicubic on held-out maps (the subjects of the val and test splits together): the true map
# box-filtered x4 down, then up again, PSNR against the truth over the whole map. Rows for the diffuse: bicubic;
# BasicSR's recipe (bilinear base, L1 pre-training); ours (bicubic base that starts at bicubic, MSE pre-training);
# ours + the GAN phase. For the other maps: bicubic and ours (what `run --sr-maps` chooses between).
# All at the demo's sizes (MSRResNet 16 features x 4 blocks, 128² crops of batch 2, Adam 2e-3) and length.
# Usage: bash bench/texture_srgan.sh <bin> <texture shards: folder with train/ val/ test/> <model> <work dir>
#        [pre-training steps (300)] [GAN steps (60)] [maps, comma-separated (diffuse)]
set -euo pipefail
bin=${1:-build/bin}; data=${2:-out/demo/texture_data}; model=${3:-out/demo/model/model.safetensors}
work=${4:-out/bench_srgan}; steps=${5:-300}; gan_steps=${6:-60}; maps=${7:-diffuse}
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
train() {  # map, run name, then flags
  local map=$1 name=$2 start=$EPOCHREALTIME
  shift 2
  [ -f "$work/$name/checkpoint.safetensors" ] && return  # trained before: its time is in $name.seconds
  "$bin/bareskin" -q --threads 2 train upscale --map "$map" --data "$data/train" --val "$heldout" --model "$model" \
    --batch 2 --patch 128 --generator "$gen" --log-every 50 --sample-every 100000 -o "$work/$name" "$@"
  $py -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$EPOCHREALTIME" \
    > "$work/$name.seconds"
}
for map in ${maps//,/ }; do
  if [ "$map" = diffuse ]; then  # the diffuse's runs keep their first names
    train diffuse basicsr --phase l1 --pixel-loss l1 --base bilinear --lr 2e-3 --steps "$steps" --eval-every "$steps" \
      --checkpoint-every "$steps"
    train diffuse ours --phase l1 --lr 2e-3 --steps "$steps" --eval-every "$steps" --checkpoint-every "$steps"
    train diffuse ours_gan --phase gan --init "$work/ours" --discriminator '{"num_feat": 16}' --lambda-perceptual 0 \
      --lr 1e-4 --steps "$gan_steps" --eval-every "$gan_steps" --checkpoint-every "$gan_steps"
  else
    train "$map" "ours_$map" --phase l1 --lr 2e-3 --steps "$steps" --eval-every "$steps" --checkpoint-every "$steps"
  fi
done
$py - "$work" "$steps" "$gan_steps" "$maps" <<'PY'
import csv, os, sys
work, steps, gan_steps, maps = sys.argv[1:5]
def last(run):
    rows = list(csv.DictReader(open(os.path.join(work, run, "eval.csv"))))
    step = max(int(r["step"]) for r in rows)
    return {r["name"]: float(r["value"]) for r in rows if int(r["step"]) == step}
print(f"SRGAN x4 on the held-out maps (val + test subjects), PSNR vs the true map (dB):")
print(f"{'map':10s} {'method':52s} {'PSNR':>7s} {'vs bicubic':>10s} {'train s':>8s}")
for m in maps.split(","):
    runs = ((("basicsr", f"BasicSR recipe: bilinear base, L1, {steps} steps"),
             ("ours", f"ours: bicubic base from bicubic, MSE, {steps} steps"),
             ("ours_gan", f"ours + GAN phase ({gan_steps} steps)")) if m == "diffuse" else
            ((f"ours_{m}", f"ours: bicubic base from bicubic, MSE, {steps} steps"),))
    base = last(runs[0][0] if m != "diffuse" else "ours")["psnr_bicubic"]
    print(f"{m:10s} {'bicubic':52s} {base:7.2f} {0:10.2f} {'-':>8s}")
    for run, label in runs:
        v = last(run)["psnr_srgan"]
        secs = open(os.path.join(work, run + ".seconds")).read().strip()
        print(f"{m:10s} {label:52s} {v:7.2f} {v - base:+10.2f} {secs:>8s}")
PY
