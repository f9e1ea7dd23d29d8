#!/usr/bin/env bash
# render --blendshapes/--expression poses a mesh; bad names and missing files get one line and exit 3, no image.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 2000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 1 --vertices 2000 --res 64 -o "$work/s" || fail "scan synth"
bs="$work/s/blendshapes/blendshapes.safetensors"
"$bin" render "$work/t/face.obj" --blendshapes "$bs" --expression jawOpen=1,mouthSmile_L=0.5 -o "$work/posed.png" \
  || fail "posed render"
"$bin" render "$work/t/face.obj" -o "$work/neutral.png" || fail "neutral render"
cmp -s "$work/posed.png" "$work/neutral.png" && fail "the expression changed nothing"
expect_failure 3 noSuchShape "$work/bad.png" -- \
  "$bin" render "$work/t/face.obj" --blendshapes "$bs" --expression noSuchShape=1 -o "$work/bad.png"
expect_failure 3 "--blendshapes" "$work/bad.png" -- "$bin" render "$work/t/face.obj" --expression jawOpen=1 -o "$work/bad.png"
expect_failure 3 "not a number" "$work/bad.png" -- \
  "$bin" render "$work/t/face.obj" --blendshapes "$bs" --expression jawOpen=wide -o "$work/bad.png"
echo "4 passed, 0 failed"
