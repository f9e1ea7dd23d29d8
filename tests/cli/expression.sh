#!/usr/bin/env bash
# render --blendshapes/--expression poses a mesh; bad names and missing files get one line and exit 3, no image.
set -u
bin=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }
"$bin" template -q --vertices 2000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 1 --vertices 2000 --res 64 -o "$work/s" || fail "scan synth"
bs="$work/s/blendshapes/blendshapes.safetensors"
"$bin" render "$work/t/face.obj" --blendshapes "$bs" --expression jawOpen=1,mouthSmile_L=0.5 -o "$work/posed.png" \
  || fail "posed render"
"$bin" render "$work/t/face.obj" -o "$work/neutral.png" || fail "neutral render"
cmp -s "$work/posed.png" "$work/neutral.png" && fail "the expression changed nothing"
"$bin" render "$work/t/face.obj" --blendshapes "$bs" --expression noSuchShape=1 -o "$work/bad.png" 2> "$work/err"
[ $? -eq 3 ] && [ "$(grep -c . "$work/err")" -eq 1 ] && grep -q noSuchShape "$work/err" && [ ! -e "$work/bad.png" ] \
  || fail "unknown blendshape: $(cat "$work/err")"
"$bin" render "$work/t/face.obj" --expression jawOpen=1 -o "$work/bad.png" 2> "$work/err"
[ $? -eq 3 ] && grep -q -- "--blendshapes" "$work/err" || fail "expression without blendshapes: $(cat "$work/err")"
"$bin" render "$work/t/face.obj" --blendshapes "$bs" --expression jawOpen=wide -o "$work/bad.png" 2> "$work/err"
[ $? -eq 3 ] && grep -q "not a number" "$work/err" || fail "bad weight: $(cat "$work/err")"
echo "4 passed, 0 failed"
