#!/usr/bin/env bash
# The CPU profile at 4K: SRGAN x4 from 1K to 4K on held-out subjects, and `bareskin run` at 4K with the profile's nets.
#   1. a 4K world: `scan synth` subjects with 4K true maps (another seed than the reference world), "registered" from
#      their truth (tests/python/truth_registered.py), `texgen make-dataset` with 1K targets and 4K high-res targets,
#      split by subject (12 train, 4 held out of 16);
#   2. `train upscale --profile cpu` for the diffuse, roughness and specular on 128² crops of the 4K maps and their 4x4
#      box-filtered 1K versions, scored on the held-out subjects' whole maps against bicubic (eval.csv: psnr_srgan,
#      psnr_bicubic; the held-out split only scores, it chooses nothing);
#   3. the speed of `bareskin run` at 4K (bench/texture_run4k.sh: skimage's astronaut, G and F of the demo): the
#      profile's UV net at 1K (its speed does not depend on its weights: one training step on this world's 1K inputs)
#      and these upscalers.
# Every stage is skipped when its output exists; trainings continue with --resume.
#   bash bench/texture_4k.sh <bin/> <demo out/> <out/> [subjects (16)] [runs (3)]
set -euo pipefail
bin=$1 demo=$2 out=$3 subjects=${4:-16} runs=${5:-3}
bareskin="$bin/bareskin"
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
model="$demo/model/model.safetensors"
[ -f "$model" ] || { echo "texture_4k: $model is missing; run 'make demo' first (it builds the model)" >&2; exit 3; }
mkdir -p "$out"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE} BARESKIN_TEMPLATE=${BARESKIN_TEMPLATE:-$demo/template}
name=texture_4k
source "$here/texture_world.sh"

# 1. The world: 4K true maps; 1K inputs and targets, 4K high-res targets; 12 subjects train, 4 held out -----------------
texture_world "$subjects" 404 4096 val --render-size 1024 --input-res 1024 --target-res 1024 --hr-res 4096 --masks 1 \
  --split 0.75,0.25,0 --seed 4
data="$out/data"

# 2. The upscalers (--profile cpu), scored on the held-out subjects -------------------------------------------------
upscalers=()
for map in diffuse roughness specular; do
  train "$out/up_$map" train upscale --profile cpu --map "$map" --data "$data/train" --val "$data/val" --model "$model" \
    --eval-every 600 --sample-every 2400 --checkpoint-every 300 --log-every 100
  upscalers+=("$out/up_$map")
done

# 3. `run` at 4K with the profile's nets: bench/texture_run4k.sh with this UV net and these upscalers ------------------
train "$out/tex1k" train texture --profile cpu --res 1024 --steps 1 --batch 1 --data "$data/train" --model "$model" \
  --checkpoint-every 1
mkdir -p "$out/run4k/nets"
for net in tex1k:tex up_diffuse:up_diffuse up_roughness:up_roughness up_specular:up_specular; do
  ln -sfn "$(cd "$out/${net%%:*}" && pwd)" "$out/run4k/nets/${net##*:}"
done
bash "$here/texture_run4k.sh" "$bin" "$demo" "$out/run4k" "$runs"

$py - "$out" <<'PY'
import csv, os, sys
out = sys.argv[1]
print("SRGAN x4 from 1K to 4K (--profile cpu), whole maps of the held-out subjects, PSNR vs the true 4K map (dB):")
print(f"{'map':10s} {'bicubic':>8s} {'SRGAN':>8s} {'gain':>6s} {'steps':>6s} {'CPU-min':>8s}")
cpu = {}  # CPU seconds per stage, summed over its runs (a resumed training has one line per run)
for line in open(os.path.join(out, "cpu.txt")):
    f = line.split()
    if len(f) == 4 and f[0] not in ("Command", "Exit"):  # GNU time's "Command terminated by signal 9" lines
        cpu[f[0]] = cpu.get(f[0], 0) + float(f[1]) + float(f[2])
for m in ("diffuse", "roughness", "specular"):
    rows = list(csv.DictReader(open(os.path.join(out, f"up_{m}", "eval.csv"))))
    step = max(int(r["step"]) for r in rows)
    v = {r["name"]: float(r["value"]) for r in rows if int(r["step"]) == step}
    print(f"{m:10s} {v['psnr_bicubic']:8.2f} {v['psnr_srgan']:8.2f} {v['psnr_srgan'] - v['psnr_bicubic']:+6.2f} "
          f"{step:6d} {cpu.get('up_' + m, float('nan')) / 60:8.1f}")
PY
