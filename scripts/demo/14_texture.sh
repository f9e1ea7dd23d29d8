#!/usr/bin/env bash
# Demo §14: texture inference — small CPU-profile trainings of the texture net (on photos of the texture subjects
# through the run pipeline: texgen run-dataset) and SRGAN (on the texture shards of §13), the end-to-end
# figure on a held-out face with makeup (with and without BareSkinNet), Table 1 at demo size, and `bareskin run` on a
# real photo. Usage: bash scripts/demo/14_texture.sh <bin> <out>. Every stage is skipped when its output exists.
source "$(dirname "$0")/lib.sh"
dir="$out/texture"
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$dir"
stage() { echo "demo §14: $*" >&2; }

# Sizes (2 cores, about 110 s for the whole section): the CPU profiles of `train texture` and `train upscale`
# (docs/texture.md, "Profiles": the UV net at 128², L1 on the UV layout; MSRResNet 16 features, 4 blocks, the pixel
# loss over bicubic) for a few hundred steps; the paper's nets and recipe are the defaults (--profile paper) at 1K
# and 4K.
RES=${DEMO_TEX_RES:-128}
STEPS=${DEMO_TEX_STEPS:-300}
UP_STEPS=${DEMO_UP_STEPS:-300}
SAMPLES=${DEMO_TABLE1_SAMPLES:-8}  # faces with makeup per Table 1 (each: 4 pipelines)
RUN_FACES=${DEMO_RUN_FACES:-12}    # photos per texture subject through the run pipeline (texgen run-dataset)
THREADS=${DEMO_THREADS:-2}
export OMP_WAIT_POLICY=PASSIVE

# Inputs of the earlier sections, found by what they are (manifest kind/split, checkpoint task), not by folder name.
eval "$($py "$here/14_texture_find.py" "$out")"
model="$out/model/model.safetensors"
[ -n "${TEX_TRAIN:-}" ] || { echo "error: $out: no texture shards (texgen make-dataset, §10–13); run the demo's earlier sections" >&2; exit 3; }

# 0. Texture samples through the run pipeline (`texgen run-dataset`, docs/texture.md): photos of the texture train
# and val subjects (makeup, light, pose, occluders) through G (§12) and F (§11), unwrapped as `run` unwraps them and
# paired with their true maps, so that the texture net learns from what `run` and `evaluate` will feed it. Without G
# or a val split the net trains on make-dataset's clean views instead.
registered="$out/registered"
teacher=(); [ -n "${RECON_RUN:-}" ] && teacher=(--teacher "$RECON_RUN")
tex_data=(--data "$TEX_TRAIN" ${TEX_VAL:+--val "$TEX_VAL"})
[ -n "${TEX_MASKS:-}" ] && tex_data+=(--masks "$TEX_MASKS")
if [ -n "${BSN_RUN:-}" ] && [ -n "${TEX_VAL:-}" ] && [ -d "$registered" ]; then
  for split in train val; do
    [ -f "$dir/run_data/$split/manifest.json" ] && continue
    [ "$split" = train ] && texture_split=$TEX_TRAIN || texture_split=$TEX_VAL
    subjects=$($py "$here/14_texture_find.py" --subjects "$texture_split")
    n=$(echo $subjects | wc -w)
    rm -rf "$dir/run_registered_$split" "$dir/run_faces_$split" && mkdir -p "$dir/run_registered_$split"
    for s in $subjects; do ln -s "$(cd "$registered/$s" && pwd)" "$dir/run_registered_$split/$s"; done
    stage "texture samples through the run pipeline ($split: $n subjects x $RUN_FACES photos)"
    timed "run faces" "$bareskin" -q --threads "$THREADS" texgen faces --registered "$dir/run_registered_$split" \
      --model "$model" --mm-subjects 1 --count $((RUN_FACES * n + RUN_FACES)) --val 0 --test 0 --seed 16 \
      --align truth -o "$dir/run_faces_$split"
    timed "run dataset" "$bareskin" -q --threads "$THREADS" texgen run-dataset --faces "$dir/run_faces_$split/train" \
      --textures "$texture_split" --model "$model" --bareskin "$BSN_RUN" "${teacher[@]}" --input-res "$RES" \
      -o "$dir/run_data/$split"
  done
  tex_data=(--data "$dir/run_data/train" --val "$dir/run_data/val")
fi
# 1. The texture net ------------------------------------------------------------------------------------------------
if [ ! -f "$dir/tex/checkpoint.safetensors" ]; then
  stage "texture net (--profile cpu) at ${RES}², $STEPS steps"
  timed "tex train" "$bareskin" -q --threads "$THREADS" train texture --profile cpu "${tex_data[@]}" --model "$model" \
    -o "$dir/tex" --res "$RES" --steps "$STEPS" --log-every 10 --eval-every 100 --sample-every "$STEPS" \
    --checkpoint-every 100
fi
# 2. SRGAN x4 on the diffuse (--profile cpu: the pixel-loss phase over the bicubic base, docs/texture.md) ------------
if [ ! -f "$dir/up/checkpoint.safetensors" ]; then
  stage "SRGAN x4 (diffuse, --profile cpu), $UP_STEPS steps"
  timed "up" "$bareskin" -q --threads "$THREADS" train upscale --profile cpu --map diffuse --data "$TEX_TRAIN" \
    ${TEX_VAL:+--val "$TEX_VAL"} --model "$model" -o "$dir/up" --steps "$UP_STEPS" --log-every 20 \
    --eval-every 100 --sample-every "$UP_STEPS" --checkpoint-every 100
fi
# 3. End to end on a held-out face with makeup, with and without BareSkinNet; bareskin run on a real photo ----------
bsn=(); [ -n "${BSN_RUN:-}" ] && bsn=(--bareskin "$BSN_RUN")
# The coefficients by the reconstruction net F of §11 when there is one (else mm-fit's fits): teacher=(...) above.
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
# 4c. A face of that subject end to end, with and without BareSkinNet, beside its truth (the report's truth strip).
if [ -n "${BSN_RUN:-}" ] && [ -f "$dir/truth_subjects.txt" ] && [ ! -d "$dir/avatar_truth_without" ]; then
  first=$(cut -d' ' -f1 "$dir/truth_subjects.txt")
  $py "$here/14_texture_find.py" --extract "$($py "$here/14_texture_find.py" --split-of "$dir/truth_faces" \
    "scan/$first")" "$dir/truth_face.png" "scan/$first"
  for variant in with without; do
    flag=("${bsn[@]}"); [ "$variant" = without ] && flag=(--no-bareskin)
    timed "run truth" "$bareskin" -q --threads "$THREADS" run "$dir/truth_face.png" -o "$dir/avatar_truth_$variant" \
      --landmarks "$dir/truth_face_lm.json" "${common[@]}" "${flag[@]}"
  done
fi
# 5. Figures and the report fragment -------------------------------------------------------------------------------
$py "$here/14_texture_find.py" --report "$out" "$dir" "$RES" "$STEPS" "$UP_STEPS" "$SAMPLES" \
  > "$out/sections/14_texture.html"
stage "wrote $out/sections/14_texture.html"
