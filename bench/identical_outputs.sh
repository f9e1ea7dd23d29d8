#!/usr/bin/env bash
# Same bytes before and after a change that must not change behaviour (a restructuring, a build switch): a tiny world
# (template, synthetic scans registered from their truth, a model), its `texgen faces` shards, and short trainings of
# F (train recon), BareSkinNet (both stages), pix2pixHD (train texture) and SRGAN (train upscale). Prints the SHA-256 of
# every shard, manifest, model and checkpoint. Paths are recorded in manifests and checkpoints, so compare two binaries
# with the same OUT (move the first OUT aside, then diff the two listings):
#   bash bench/identical_outputs.sh OLD_BIN/bareskin OUT > old.txt; mv OUT OUT.old
#   bash bench/identical_outputs.sh NEW_BIN/bareskin OUT > new.txt; diff old.txt new.txt && echo identical
set -eu
[ $# -eq 2 ] || { echo "usage: bash bench/identical_outputs.sh BARESKIN_BINARY OUT" >&2; exit 2; }
tests=$(cd "$(dirname "$0")/../tests" && pwd)
source "$tests/cli/lib.sh" "$1"
here=$tests/cli  # lib.sh takes its caller's folder for tests/cli
trap - EXIT
rm -rf "$work"
work=$2
[ ! -e "$work" ] || { echo "$work: exists; give a new folder" >&2; exit 3; }
mkdir -p "$work"
tiny_face_world
"$bin" texgen faces -q --threads 2 --registered "$work/r" --model "$model" --mm-subjects 5 --val 1 --test 2 --seed 3 \
  --align truth --map-size 64 --layer-size 32 --backgrounds "" --count 24 --shard-size 2 -o "$work/faces"
"$bin" -q --threads 1 train recon --arch resnet18 --width 4 --gamma on --data "$work/faces" --model "$model" \
  -o "$work/F" --steps 4 --batch 2 --checkpoint-every 2 --eval-every 0 --sample-every 0 --log-every 1 --image-size 64
"$bin" -q --threads 1 train bareskin --data "$work/faces" --steps1 3 --steps2 2 --teacher "$work/F" --model "$model" \
  -o "$work/bsn" --size 64 --batch 2 --g-options '{"ngf": 8}' --d-options '{"ndf": 8, "n_layers": 2}' \
  --log-every 1 --checkpoint-every 2 --eval-every 0 --sample-every 0 --eval-samples 2
fixture="$py $tests/python/texture_cli_fixture.py"
$fixture model "$work/a.safetensors" 1
$fixture shards "$work/texshards" 4
"$bin" -q --threads 1 train texture --data "$work/texshards" -o "$work/tex" --model "$work/a.safetensors" --res 32 \
  --steps 3 --batch 2 --generator '{"ngf": 4, "n_downsampling": 2, "n_blocks": 1}' \
  --discriminator '{"ndf": 4, "n_layers": 1}'
"$bin" -q --threads 1 train upscale --map diffuse --phase l1 --data "$work/texshards" -o "$work/up" \
  --model "$work/a.safetensors" --steps 3 --batch 2 --generator '{"num_feat": 4, "num_block": 1}'
cd "$work"
find . \( -name '*.tar' -o -name 'manifest.json' -o -name '*.safetensors' \) | sort | xargs sha256sum
