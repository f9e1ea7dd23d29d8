#!/usr/bin/env bash
# The texture half of the CPU reference (after bench/cpu_reference.sh's G): texture inference trained and scored on a
# world of its own, on held-out subjects.
#   1. a texture world: `scan synth` subjects (the demo's template and generator settings, another seed) "registered"
#      from their truth (tests/python/truth_registered.py: the template on the true correspondence, the true maps in
#      the template UV), then `texgen make-dataset` (the diffuse-only unwrap, what BareSkinNet hands over), split by
#      subject 80/10/10;
#   2. the texture net (`train texture --profile cpu`: the UV net) and SRGAN x4 (`train upscale --profile cpu`) on
#      the diffuse, roughness and specular, their validation curves against the 3DMM-only maps and bicubic (eval.csv);
#   3. Table 1 (`bareskin evaluate`) on faces with makeup of the test subjects, with the G and F of
#      bench/cpu_reference.sh (CPU_REFERENCE=<its out/>);
#   4. per G, the texture net trained through the run pipeline (`texgen run-dataset`: photos of the train and val
#      subjects through that G and F) and Table 1 again with it.
# Every stage is skipped when its output exists; trainings continue with --resume.
#   [CPU_REFERENCE=<bench/cpu_reference.sh out/>] bash bench/cpu_reference_texture.sh <bin/> <demo out/> <out/> [subjects]
set -euo pipefail
bin=$1 demo=$2 out=$3 subjects=${4:-60}
bareskin="$bin/bareskin"
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
model="$demo/model/model.safetensors"
[ -f "$model" ] || { echo "cpu_reference_texture: $model is missing; run 'make demo' first (it builds the model)" >&2; exit 3; }
mkdir -p "$out"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE} BARESKIN_TEMPLATE=${BARESKIN_TEMPLATE:-$demo/template}
name=cpu_reference_texture
source "$here/texture_world.sh"

# 1. The world ------------------------------------------------------------------------------------------------------
texture_world "$subjects" 101 1024 test --render-size 512 --input-res 256 --target-res 256 --hr-res 1024 --masks 3 \
  --split 0.8,0.1,0.1 --seed 3
data="$out/data"

# 2. The texture net and the upscalers (--profile cpu), validated on the val subjects --------------------------------
train "$out/tex" train texture --profile cpu --data "$data/train" --val "$data/val" --masks "$data/masks" \
  --model "$model" --eval-every 100 --sample-every 500 --checkpoint-every 100 --log-every 50
upscalers=()
for map in diffuse roughness specular; do
  train "$out/up_$map" train upscale --profile cpu --map "$map" --data "$data/train" --val "$data/val" --model "$model" \
    --eval-every 100 --sample-every 600 --checkpoint-every 100 --log-every 50
  upscalers+=("$out/up_$map")
done

# 3. Table 1 on faces with makeup of the test subjects (column b against their true maps), with the G and F of
# bench/cpu_reference.sh (<ref>/G_seed0, <ref>/F) and, when <ref>/G_before exists (a G trained as the paper's stage
# 1, towards the before-makeup photo: it removes makeup and keeps the light), with that G too.
ref=${CPU_REFERENCE:-}
if [ -n "$ref" ] && [ -d "$ref/G_seed0" ]; then
  find="$here/../scripts/demo/14_texture_find.py"
  subject_faces test 8 14 "$out/faces" test
  split_test=$($py "$find" --split-of "$out/faces" "scan/$(ls "$out/test_registered" | head -1)")
  for g in G_seed0 G_before; do
    [ -d "$ref/$g" ] && [ ! -f "$out/table1_$g/table.md" ] || continue
    echo "cpu_reference_texture: Table 1 with $g" >&2
    cpu "table1_$g" "$bareskin" -q --threads 2 evaluate --faces "$split_test" --textures "$data/test" --model "$model" \
      --texture "$out/tex" --upscale "${upscalers[@]}" --bareskin "$ref/$g" --teacher "$ref/F" --max-samples 40 \
      -o "$out/table1_$g"
  done
fi

# 4. The texture net trained through the run pipeline (`texgen run-dataset`), once per G: faces of the train and val
# subjects, each photo through that G and the F of Table 1, unwrapped with its face mask and paired with the true
# maps; then Table 1 again with that net (table1_<G>_run).
if [ -n "$ref" ] && [ -d "$ref/G_seed0" ]; then
  subject_faces train "${RUN_FACES_PER_SUBJECT:-20}" 15 "$out/faces_train"
  subject_faces val 10 15 "$out/faces_val"
  for g in G_seed0 G_before; do
    [ -d "$ref/$g" ] || continue
    for split in train val; do
      [ -f "$out/run_data_$g/$split/manifest.json" ] || cpu "run_data_${g}_$split" "$bareskin" -q --threads 2 \
        texgen run-dataset --faces "$out/faces_$split/train" --textures "$data/$split" --model "$model" \
        --bareskin "$ref/$g" --teacher "$ref/F" --input-res 256 -o "$out/run_data_$g/$split"
    done
    train "$out/tex_run_$g" train texture --profile cpu --data "$out/run_data_$g/train" \
      --val "$out/run_data_$g/val" --model "$model" --eval-every 100 --sample-every 500 --checkpoint-every 100 \
      --log-every 50
    if [ ! -f "$out/table1_${g}_run/table.md" ]; then
      cpu "table1_${g}_run" "$bareskin" -q --threads 2 evaluate --faces "$split_test" --textures "$data/test" \
        --model "$model" --texture "$out/tex_run_$g" --upscale "${upscalers[@]}" --bareskin "$ref/$g" \
        --teacher "$ref/F" --max-samples 40 -o "$out/table1_${g}_run"
    fi
  done
fi

$py "$here/cpu_reference_texture.py" "$out"
for table in "$out"/table1_*/; do  # Table 1's gains with their 95% intervals over subjects
  if [ -f "$table/per_sample.csv" ]; then $py "$here/table1_intervals.py" "$table"; fi
done
