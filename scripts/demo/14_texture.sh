#!/usr/bin/env bash
# Demo §14: texture inference — tiny pix2pixHD and SRGAN trainings on the texture shards of §10–13, the end-to-end
# figure on a held-out face with makeup (with and without BareSkinNet), Table 1 at demo size, and `bareskin run` on a
# real photo. Usage: bash scripts/demo/14_texture.sh <bin> <out>. Every stage is skipped when its output exists.
source "$(dirname "$0")/lib.sh"
dir="$out/texture"
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$dir"
stage() { echo "demo §14: $*" >&2; }

# Sizes (2 cores, 180 s for the whole section): nets at 64² maps (pix2pixHD ngf 16, 3 downsamplings, 3 blocks;
# MSRResNet 16 features, 4 blocks), a few hundred steps, and no perceptual term (VGG16 on the four maps costs ~20x the
# tiny generator's step; the tests and the paper-size runs keep it) but an L1 term x10 and a higher rate (5e-4), so
# that 200 steps converge at all; the paper's nets and recipe are the defaults at 1K and 4K.
RES=${DEMO_TEX_RES:-64}
STEPS=${DEMO_TEX_STEPS:-200}
UP_STEPS=${DEMO_UP_STEPS:-300}
UP_GAN_STEPS=${DEMO_UP_GAN_STEPS:-40}
SAMPLES=${DEMO_TABLE1_SAMPLES:-8}  # faces with makeup per Table 1 (each: 4 pipelines at 64², ~0.5 s each)
THREADS=${DEMO_THREADS:-2}
export OMP_WAIT_POLICY=PASSIVE

# Inputs of the earlier sections, found by what they are (manifest kind/split, checkpoint task), not by folder name.
eval "$($py "$here/14_texture_find.py" "$out")"
model="$out/model/model.safetensors"
[ -n "${TEX_TRAIN:-}" ] || { echo "error: $out: no texture shards (texgen make-dataset, §10–13); run the demo's earlier sections" >&2; exit 3; }

# 1. pix2pixHD ------------------------------------------------------------------------------------------------------
if [ ! -f "$dir/tex/checkpoint.safetensors" ]; then
  stage "pix2pixHD at ${RES}², $STEPS steps"
  masks=(); [ -n "${TEX_MASKS:-}" ] && masks=(--masks "$TEX_MASKS")
  timed "tex train" "$bareskin" -q --threads "$THREADS" train texture --data "$TEX_TRAIN" ${TEX_VAL:+--val "$TEX_VAL"} \
    "${masks[@]}" --model "$model" -o "$dir/tex" --res "$RES" --steps "$STEPS" --batch 2 \
    --generator '{"ngf": 16, "n_downsampling": 3, "n_blocks": 3}' --discriminator '{"ndf": 16, "n_layers": 2}' \
    --lambda-perceptual 0 --lambda-l1 10 --lr 5e-4 --log-every 10 --eval-every 100 --sample-every 100 --checkpoint-every 100
fi
# 2. SRGAN x4 on the diffuse: pixel-loss pre-training (MSE, bicubic base: docs/texture.md), then the GAN phase -------
if [ ! -f "$dir/up/checkpoint.safetensors" ]; then
  stage "SRGAN x4 (diffuse), $UP_STEPS + $UP_GAN_STEPS steps"
  gen='{"num_feat": 16, "num_block": 4}'
  timed "up l1" "$bareskin" -q --threads "$THREADS" train upscale --map diffuse --phase l1 --data "$TEX_TRAIN" \
    ${TEX_VAL:+--val "$TEX_VAL"} --model "$model" -o "$dir/up_l1" --steps "$UP_STEPS" --batch 2 --generator "$gen" --lr 2e-3 \
    --log-every 20 --eval-every "$UP_STEPS" --sample-every "$UP_STEPS" --checkpoint-every "$UP_STEPS"
  timed "up gan" "$bareskin" -q --threads "$THREADS" train upscale --map diffuse --phase gan --init "$dir/up_l1" \
    --data "$TEX_TRAIN" ${TEX_VAL:+--val "$TEX_VAL"} --model "$model" -o "$dir/up" --steps "$UP_GAN_STEPS" --batch 2 \
    --generator "$gen" --discriminator '{"num_feat": 16}' --lambda-perceptual 0 --log-every 10 \
    --eval-every "$UP_GAN_STEPS" --sample-every "$UP_GAN_STEPS" --checkpoint-every "$UP_GAN_STEPS"
fi
# 3. End to end on a held-out face with makeup, with and without BareSkinNet; bareskin run on a real photo ----------
bsn=(); [ -n "${BSN_RUN:-}" ] && bsn=(--bareskin "$BSN_RUN")
# The coefficients by the reconstruction net F of §11 when there is one (else mm-fit's fits).
teacher=(); [ -n "${RECON_RUN:-}" ] && teacher=(--teacher "$RECON_RUN")
common=(--model "$model" --texture "$dir/tex" --upscale "$dir/up" --preview-size 256 "${teacher[@]}")
if [ -n "${FACES_TEST:-}" ] && [ ! -f "$dir/heldout_lm.json" ]; then
  $py "$here/14_texture_find.py" --extract "$FACES_TEST" "$dir/heldout.png"
fi
for variant in with without; do
  [ "$variant" = with ] && [ -z "${BSN_RUN:-}" ] && continue
  flag=("${bsn[@]}"); [ "$variant" = without ] && flag=(--no-bareskin)
  if [ -f "$dir/heldout.png" ] && [ ! -d "$dir/avatar_heldout_$variant" ]; then
    timed "run $variant" "$bareskin" -q --threads "$THREADS" run "$dir/heldout.png" -o "$dir/avatar_heldout_$variant" \
      --landmarks "$dir/heldout_lm.json" "${common[@]}" "${flag[@]}"
  fi
done
astronaut=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
if [ ! -d "$dir/avatar_astronaut" ]; then
  flag=(--no-bareskin); [ -n "${BSN_RUN:-}" ] && flag=("${bsn[@]}")
  timed "run photo" "$bareskin" -q --threads "$THREADS" run "$astronaut" -o "$dir/avatar_astronaut" "${common[@]}" \
    "${flag[@]}"
fi
# 4. Table 1 at demo size ------------------------------------------------------------------------------------------
if [ -n "${BSN_RUN:-}" ] && [ -n "${FACES_TEST:-}" ] && [ ! -f "$dir/table1/table.md" ]; then
  stage "Table 1 on $SAMPLES held-out samples"
  timed "table 1" "$bareskin" -q --threads "$THREADS" evaluate --faces "$FACES_TEST" ${TEX_TEST:+--textures "$TEX_TEST"} \
    --model "$model" --texture "$dir/tex" --upscale "$dir/up" --bareskin "$BSN_RUN" --max-samples "$SAMPLES" \
    "${teacher[@]}" -o "$dir/table1"
fi
# 4b. Column (b) of Table 1: faces of the texture test split's subjects (the held-out faces above have no true maps),
# rendered by texgen faces from their registered scans beside one 3DMM subject (the generator keeps a training
# subject); the split holding the scan subject is evaluated against the true maps.
registered="$out/registered"
if [ -n "${BSN_RUN:-}" ] && [ -n "${TEX_TEST:-}" ] && [ -d "$registered" ] && [ ! -f "$dir/table1_truth/table.md" ]; then
  stage "Table 1 column (b) on faces of the texture test subjects"
  subjects=$($py "$here/14_texture_find.py" --subjects "$TEX_TEST")
  rm -rf "$dir/truth_registered" "$dir/truth_faces"
  mkdir -p "$dir/truth_registered"
  for s in $subjects; do ln -s "$(cd "$registered/$s" && pwd)" "$dir/truth_registered/$s"; done
  n=$(echo $subjects | wc -w)
  timed "truth faces" "$bareskin" -q --threads "$THREADS" texgen faces --registered "$dir/truth_registered" \
    --model "$model" --mm-subjects 1 --count $((SAMPLES * n + SAMPLES)) --val 0 --test "$n" --seed 14 --align truth \
    -o "$dir/truth_faces"
  first=$(echo $subjects | cut -d' ' -f1)
  truth_split=$($py "$here/14_texture_find.py" --split-of "$dir/truth_faces" "scan/$first")
  echo $subjects > "$dir/truth_subjects.txt"
  timed "table 1 (b)" "$bareskin" -q --threads "$THREADS" evaluate --faces "$truth_split" --textures "$TEX_TEST" \
    --model "$model" --texture "$dir/tex" --upscale "$dir/up" --bareskin "$BSN_RUN" --max-samples "$SAMPLES" \
    "${teacher[@]}" -o "$dir/table1_truth"
fi
# 5. Figures and the report fragment -------------------------------------------------------------------------------
$py "$here/14_texture_find.py" --report "$out" "$dir" "$RES" "$STEPS" "$UP_STEPS" "$SAMPLES" "$UP_GAN_STEPS" \
  > "$out/sections/14_texture.html"
stage "wrote $out/sections/14_texture.html"
