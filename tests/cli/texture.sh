#!/usr/bin/env bash
# bareskin train texture / upscale, run: tiny trainings on procedural shards, then the bad inputs of `run` (a photo
# without a face, a corrupt photo, runs that do not fit each other or the model): one line, exit 3, no avatar folder;
# then one run that succeeds, with its light files.
source "$(dirname "$0")/lib.sh" "$@"
fixture="$py $here/../python/texture_cli_fixture.py"
$fixture model "$work/a.safetensors" 1 && $fixture model "$work/b.safetensors" 2 || fail "fixture models"
$fixture shards "$work/shards" 4 && $fixture shards "$work/no_normal" 2 mm_normal || fail "fixture shards"
astronaut=/usr/lib/python3/dist-packages/skimage/data/astronaut.png

"$bin" -q train texture --data "$work/shards" -o "$work/tex" --model "$work/a.safetensors" --res 32 --steps 2 \
  --batch 2 --generator '{"ngf": 4, "n_downsampling": 2, "n_blocks": 1}' --discriminator '{"ndf": 4, "n_layers": 1}' \
  --lambda-perceptual 0 || fail "train texture"
[ -f "$work/tex/checkpoint.safetensors" ] || fail "no texture checkpoint"
"$bin" -q train upscale --map diffuse --phase l1 --data "$work/shards" -o "$work/up" --model "$work/a.safetensors" \
  --steps 2 --batch 2 --generator '{"num_feat": 4, "num_block": 1}' --clip-grad-norm 100 --log-every 1 \
  || fail "train upscale"
grep -q '^2,G/grad_norm,' "$work/up/metrics.csv" || fail "train upscale --clip-grad-norm logged no G/grad_norm"
grep -q '"model_crc32"' "$work/tex/config.json" || fail "the model's CRC-32 is not recorded"
# Beside the CPU profile, another architecture's --generator replaces the UV net's options (its "fill") whole.
"$bin" -q train texture --profile cpu --arch global --data "$work/shards" -o "$work/tex_p" --model "$work/a.safetensors" \
  --res 32 --steps 1 --batch 2 --generator '{"ngf": 4, "n_downsampling": 2, "n_blocks": 1}' \
  || fail "train texture --profile cpu --arch global with its own --generator"

# Training: a sample without a member, crops larger than the maps, an unknown map, a GAN phase from another map's run.
expect_failure 3 "mm_normal" "$work/t2" -- "$bin" -q train texture --data "$work/no_normal" -o "$work/t2" --res 32 \
  --steps 1 --generator '{"ngf": 4, "n_downsampling": 2, "n_blocks": 1}'
expect_failure 3 "--map" "" -- "$bin" -q train upscale --map albedo --data "$work/shards" -o "$work/u2"
expect_failure 3 "patch" "" -- "$bin" -q train upscale --map diffuse --patch 100 --data "$work/shards" -o "$work/u3"
expect_failure 3 "smaller than the patch" "$work/u3" -- "$bin" -q train upscale --map diffuse --patch 256 \
  --data "$work/shards" -o "$work/u3"
expect_failure 3 "not srgan-normal" "" -- "$bin" -q train upscale --map normal --phase gan --init "$work/up" \
  --data "$work/shards" -o "$work/u4" --steps 1

# run: every refusal leaves no avatar folder (a texture run given as the reconstruction net F included).
run() { "$bin" -q run "$@" -o "$work/avatar"; }
$py -c "import numpy as np; from PIL import Image; Image.fromarray(np.full((256, 256, 3), 128, np.uint8)).save('$work/grey.png')"
echo "not an image" > "$work/corrupt.png"
expect_failure 3 "no face" "$work/avatar" -- run "$work/grey.png" --model "$work/a.safetensors" --texture "$work/tex" \
  --no-bareskin
expect_failure 3 "another morphable model" "$work/avatar" -- run "$astronaut" --model "$work/b.safetensors" \
  --texture "$work/tex" --no-bareskin
expect_failure 3 "not a texture model" "$work/avatar" -- run "$astronaut" --model "$work/a.safetensors" \
  --texture "$work/up" --no-bareskin
expect_failure 3 "not an upscaler" "$work/avatar" -- run "$astronaut" --model "$work/a.safetensors" \
  --texture "$work/tex" --upscale "$work/tex" --no-bareskin
expect_failure 3 "as another --upscale run" "$work/avatar" -- run "$astronaut" --model "$work/a.safetensors" \
  --texture "$work/tex" --upscale "$work/up" "$work/up" --no-bareskin
expect_failure 3 "not BareSkinNet" "$work/avatar" -- run "$astronaut" --model "$work/a.safetensors" \
  --texture "$work/tex" --bareskin "$work/tex"
expect_failure 3 "not a checkpoint of 'bareskin train recon'" "$work/avatar" -- run "$astronaut" \
  --model "$work/a.safetensors" --texture "$work/tex" --no-bareskin --teacher "$work/tex"
error_ok 3 "corrupt.png" "$work/avatar" -- run "$work/corrupt.png" --model "$work/a.safetensors" --texture "$work/tex" \
  --no-bareskin || error_ok 4 "corrupt.png" "$work/avatar" -- run "$work/corrupt.png" --model "$work/a.safetensors" \
  --texture "$work/tex" --no-bareskin || fail "corrupt photo -> exit $error_code: $(cat "$work/err")"
expect_failure 2 "--no-bareskin" "$work/avatar" -- run "$astronaut" --model "$work/a.safetensors" --texture "$work/tex"
# run, without BareSkinNet (3DMM fit, the tiny texture net): a complete avatar folder, the GLB by its header, and the
# light the photo was fitted with as 27 SH numbers and as an equirectangular EXR that oiiotool reads.
"$bin" -q run "$astronaut" --model "$work/a.safetensors" --texture "$work/tex" --no-bareskin --preview-size 64 \
  -o "$work/ok" || fail "run"
for f in avatar.glb mesh.obj coefficients.json maps/diffuse.png maps/normal.png maps/roughness.png maps/specular.png \
  preview_light1.png light_sh.json light_env.exr; do
  [ -s "$work/ok/$f" ] || fail "run wrote no $f"
done
[ "$(head -c 4 "$work/ok/avatar.glb")" = glTF ] || fail "avatar.glb is not a GLB"
$py -c 'import json, math, sys; g = json.load(open(sys.argv[1])); assert len(g) == 27 and all(math.isfinite(x) for x in g), g' \
  "$work/ok/light_sh.json" || fail "light_sh.json is not 27 SH coefficients"
oiiotool --info "$work/ok/light_env.exr" | grep -q "64 x  *32, 3 channel" || fail "light_env.exr is not a 64x32 RGB EXR"
echo "texture CLI: ok"
