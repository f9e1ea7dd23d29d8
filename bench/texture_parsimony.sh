#!/usr/bin/env bash
# Texture inference, parsimony: pix2pixHD generator width (ngf) vs held-out PSNR (mean of the four maps) vs training
# time, at CPU size (64² maps, 3 downsamplings, 3 blocks, 200 steps of batch 2, the demo's recipe), and the default
# pick: the smallest width within 0.5 dB of the best. Then `bareskin run` latency per stage with the picked net.
# Usage: bash bench/texture_parsimony.sh <bin> <texture shards: folder with train/ val/ masks/> <model> <work dir>
set -euo pipefail
bin=${1:-build/bin}; data=${2:-out/h21/textures}; model=${3:-out/demo/model/model.safetensors}; work=${4:-out/bench_texture}
export OMP_WAIT_POLICY=PASSIVE
mkdir -p "$work"
printf '%-6s %12s %14s %10s\n' ngf parameters "PSNR (dB)" seconds
for ngf in ${WIDTHS:-8 16 32}; do
  run="$work/ngf$ngf"
  start=$EPOCHREALTIME
  [ -f "$run/checkpoint.safetensors" ] || "$bin/bareskin" -q --threads 2 train texture --data "$data/train" \
    --val "$data/val" --masks "$data/masks" -o "$run" --res 64 --steps 200 --batch 2 --lambda-perceptual 0 \
    --lambda-l1 10 --lr 5e-4 --generator "{\"ngf\": $ngf, \"n_downsampling\": 3, \"n_blocks\": 3}" \
    --discriminator '{"ndf": 16, "n_layers": 2}' --log-every 50 --eval-every 200 --sample-every 200 \
    --checkpoint-every 200
  seconds=$(/usr/bin/python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.1f}')" "$start" "$EPOCHREALTIME")
  params=$("$bin/bareskin" train --print-model pix2pixhd_global --options \
    "{\"in_channels\": 13, \"out_channels\": 8, \"ngf\": $ngf, \"n_downsampling\": 3, \"n_blocks\": 3}" \
    | grep -oP '^parameters: \K[0-9,]+')
  psnr=$(/usr/bin/python3 -c "
import csv, sys
rows = [r for r in csv.DictReader(open(sys.argv[1])) if r['name'].startswith('psnr_')]
last = max(int(r['step']) for r in rows)
v = [float(r['value']) for r in rows if int(r['step']) == last]
print(f'{sum(v) / len(v):.2f}')" "$run/eval.csv")
  printf '%-6s %12s %14s %10s\n' "$ngf" "$params" "$psnr" "$seconds" | tee -a "$work/table.txt"
done
/usr/bin/python3 - "$work/table.txt" <<'PY'
import sys
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
best = max(float(r[2]) for r in rows)
pick = min((int(r[0]) for r in rows if float(r[2]) >= best - 0.5))
print(f"best {best:.2f} dB; default = smallest ngf within 0.5 dB: {pick}")
PY
