#!/usr/bin/env bash
# Learning, stage 2 (de-lighting): on the held-out test subjects of a tiny `texgen faces` world, the unlit albedo
# the teacher F fits to G's output (eval.json's psnr_albedo_bare, against the bare truth) is better after stage 2
# (G + E through the 3DMM render, --profile cpu) than after stage 1 alone. A stage-2 loss that never reaches G (broken
# or detached) leaves G as stage 1 left it, which fails here.
source "$(dirname "$0")/lib.sh" "$@"
tiny_face_world
"$bin" texgen faces -q --threads 2 --registered "$work/r" --model "$model" --mm-subjects 40 --val 0 --test 8 \
  --seed 5 --align truth --map-size 64 --layer-size 32 --backgrounds "" --count 240 --shard-size 64 -o "$work/faces" \
  || fail "texgen faces"
# The teacher F, as in learning.sh: a ResNet-18 of width 8 at 64² supervised by the samples' coefficients.
"$bin" -q --threads 2 train recon --profile cpu --width 8 --image-size 64 --data "$work/faces" --model "$model" \
  -o "$work/F" --steps 150 --checkpoint-every 1000 --eval-every 0 --sample-every 0 --log-every 50 --supervision truth \
  || fail "train recon"
common=(-q --threads 2 train bareskin --profile cpu --data "$work/faces" --teacher "$work/F" --model "$model"
  --steps1 ${LEARNING_G_STEPS:-150} --ema-g 0 --student-options '{"width": 8}' --log-every 50 --checkpoint-every 1000
  --eval-every 0 --sample-every 0 -o "$work/G")
"$bin" "${common[@]}" --steps2 0 || fail "train bareskin, stage 1"
cp "$work/G/eval.json" "$work/stage1.json"
"$bin" "${common[@]}" --steps2 ${LEARNING_G2_STEPS:-60} --resume || fail "train bareskin, stage 2"
"$py" - "$work/stage1.json" "$work/G/eval.json" <<'PY' || fail "stage 2 did not improve the albedo"
import json, sys
s1, s2 = (json.load(open(p))["mean"] for p in sys.argv[1:])
a1, a2, a0 = s1["psnr_albedo_bare"], s2["psnr_albedo_bare"], s1["psnr_albedo_input_bare"]
print(f"F's unlit albedo vs bare: from the input {a0:.2f} dB, after stage 1 {a1:.2f} dB, after stage 2 {a2:.2f} dB "
      f"({a2 - a1:+.2f} dB)")
assert a2 > a1, (s1, s2)
PY
