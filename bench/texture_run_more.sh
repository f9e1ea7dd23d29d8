#!/usr/bin/env bash
# More run-pipeline data for the texture net (after bench/cpu_reference_texture.sh): PER photos of each train subject
# of its texture world through the bare-target G and F of the CPU reference (`texgen faces`, seed 25; `texgen
# run-dataset`), the profile's UV net trained STEPS steps on them (validated on step 4's val photos), and Table 1 on
# the same 40 held-out faces (table1_G_seed0_run<PER>; 95% intervals by bench/table1_intervals.py).
# Every stage is skipped when its output exists; the training continues with --resume.
#   bash bench/texture_run_more.sh <bin/> <demo out/> <cpu_reference out/> <cpu_reference_texture out/> [PER] [STEPS]
set -euo pipefail
bin=$1 demo=$2 ref=$3 out=$4 per=${5:-60} steps=${6:-3000}
bareskin="$bin/bareskin"
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
model="$demo/model/model.safetensors"
name=texture_run_more
for f in "$model" "$ref/G_seed0" "$ref/F" "$out/run_data_G_seed0/val/manifest.json" "$out/data/train"; do
  [ -e "$f" ] || { echo "$name: $f is missing; run bench/cpu_reference.sh (with its texture step) first" >&2; exit 3; }
done
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE} BARESKIN_TEMPLATE=${BARESKIN_TEMPLATE:-$demo/template}
source "$here/texture_world.sh"  # cpu, train, subject_faces

subject_faces train "$per" 25 "$out/faces_train$per"
[ -f "$out/run_data$per/train/manifest.json" ] || cpu "run_data$per" "$bareskin" -q --threads 2 texgen run-dataset \
  --faces "$out/faces_train$per/train" --textures "$out/data/train" --model "$model" --bareskin "$ref/G_seed0" \
  --teacher "$ref/F" --input-res 256 -o "$out/run_data$per/train"
train "$out/tex_run$per" train texture --profile cpu --steps "$steps" --data "$out/run_data$per/train" \
  --val "$out/run_data_G_seed0/val" --model "$model" --eval-every 250 --sample-every 1000 --checkpoint-every 250 \
  --log-every 50
split=$($py "$here/../scripts/demo/14_texture_find.py" --split-of "$out/faces" "scan/$(ls "$out/test_registered" | head -1)")
[ -f "$out/table1_G_seed0_run$per/table.md" ] || cpu "table1_run$per" "$bareskin" -q --threads 2 evaluate \
  --faces "$split" --textures "$out/data/test" --model "$model" --texture "$out/tex_run$per" \
  --upscale "$out/up_diffuse" "$out/up_roughness" "$out/up_specular" --bareskin "$ref/G_seed0" --teacher "$ref/F" \
  --max-samples 40 -o "$out/table1_G_seed0_run$per"
$py "$here/table1_intervals.py" "$out/table1_G_seed0_run$per"
