#!/usr/bin/env bash
# The chart the CPU profile of `train texture` was chosen from: texture generators (pix2pixHD's GlobalGenerator and
# the UV net, at several widths and working resolutions) trained for the same steps on one texture world, each scored
# on its held-out validation subjects (eval.csv: PSNR per map against the true maps, and the 3DMM-only maps' PSNR),
# against the CPU-minutes its training took on 2 cores. A run whose last evaluation exists is kept; a killed one
# continues with --resume.
#   bash bench/texture_profile_sweep.sh <bin/> <texture data/> <out/> [steps]
# (<texture data/>: `texgen make-dataset`'s folder, e.g. bench/cpu_reference_texture.sh's <out>/data)
set -euo pipefail
bin=$1 data=$2 out=$3 steps=${4:-400}
mkdir -p "$out"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE}
# name|flags over the common recipe below (L1 on the layout x10, lr 1e-3, batch 4); $l1only: without D
l1only="--lambda-gan 0 --lambda-feat 0"
configs=(
  "pix2pixhd-gan-ngf16-128|--arch global --res 128 --generator {\"ngf\":16,\"n_downsampling\":3,\"n_blocks\":3} --lambda-gan 1 --lambda-feat 10"
  "global-ngf16-128|--arch global --res 128 --generator {\"ngf\":16,\"n_downsampling\":3,\"n_blocks\":3} $l1only"
  "uv-ngf8-128|--arch uv --res 128 --generator {\"ngf\":8} $l1only"
  "uv-ngf16-128|--arch uv --res 128 --generator {\"ngf\":16} $l1only"
  "uv-ngf32-128|--arch uv --res 128 --generator {\"ngf\":32} $l1only"
  "uv-ngf16-256|--arch uv --res 256 --generator {\"ngf\":16} $l1only"
)
for c in "${configs[@]}"; do
  name=${c%%|*} flags=${c#*|}
  run="$out/$name"
  grep -q "^$steps,psnr_diffuse," "$run/eval.csv" 2>/dev/null && continue
  resume=()
  [ -f "$run/checkpoint.safetensors" ] && resume=(--resume)
  echo "sweep: $name ($steps steps)" >&2
  # shellcheck disable=SC2086 # the flags split on spaces by design
  /usr/bin/time -f "$name %U %S %e" -a -o "$out/cpu.txt" "$bin/bareskin" -q --threads 2 train texture \
    --data "$data/train" --val "$data/val" --masks "$data/masks" -o "$run" --steps "$steps" --batch 4 \
    --discriminator '{"ndf": 16, "n_layers": 2}' --lambda-perceptual 0 --lambda-l1 10 --lr 1e-3 \
    --eval-every 100 --sample-every "$steps" --checkpoint-every 100 --log-every 50 "${resume[@]}" $flags
done
/usr/bin/python3 "$(dirname "$0")/texture_profile_sweep.py" "$out" "${configs[@]%%|*}"
