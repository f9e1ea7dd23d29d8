#!/usr/bin/env bash
# The chart the CPU profile of `train bareskin` was chosen from: G variants (head, width, depth, resolution) trained
# for the same stage-1 steps on one `texgen faces` world, each scored on its held-out test split (eval.json: PSNR
# against the bare truth on skin, on the whole face and on the makeup region), against the CPU-minutes its training
# took on 2 cores. Runs whose eval.json exists are kept, a killed one continues with --resume.
#   bash bench/cpu_profile_sweep.sh <bin/> <faces/> <out/> [steps]
set -euo pipefail
bin=$1 faces=$2 out=$3 steps=${4:-400}
mkdir -p "$out"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE}
# name|flags over --profile cpu
configs=(
  "residual-ngf16-64|--head residual"
  "affine-ngf8-64|--g-options {\"ngf\":8}"
  "affine-ngf16-64|"
  "affine-ngf32-64|--g-options {\"ngf\":32}"
  "affine-ngf16-64-depth5|--g-options {\"ngf\":16,\"num_downs\":5}"
  "affine-ngf16-128|--size 128"
)
for c in "${configs[@]}"; do
  name=${c%%|*} flags=${c#*|}
  run="$out/$name"
  [ -f "$run/eval.json" ] && continue
  resume=()
  [ -f "$run/stage1/checkpoint.safetensors" ] && resume=(--resume)
  echo "sweep: $name ($steps steps)" >&2
  # shellcheck disable=SC2086 # the flags split on spaces by design
  /usr/bin/time -f "$name %U %S %e" -a -o "$out/cpu.txt" "$bin/bareskin" -q --threads 2 train bareskin --profile cpu \
    --data "$faces" -o "$run" --steps1 "$steps" --steps2 0 --ema-g 0 --eval-every 100 --sample-every 0 \
    --checkpoint-every 100 --log-every 50 --eval-samples 200 "${resume[@]}" $flags
done
/usr/bin/python3 "$(dirname "$0")/cpu_profile_sweep.py" "$out" "${configs[@]%%|*}"
