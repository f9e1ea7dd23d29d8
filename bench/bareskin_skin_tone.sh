#!/usr/bin/env bash
# The recovered skin's error by skin tone (ITA groups) on held-out subjects: a `texgen faces` world of 3DMM
# identities none of the training worlds drew (its own seed, every subject in test; `--skin-tones balanced`, so each
# of the six ITA groups holds a sixth of them), G of a trained run on its photos
# (`bareskin demakeup --aligned`), and the table of bench/bareskin_skin_tone.py. Steps whose outputs exist are
# skipped. (texgen faces keeps one subject for training: it is not used.)
#   bash bench/bareskin_skin_tone.sh <bin/> <G run> <model.safetensors> <out/> [subjects=80]
set -euo pipefail
bin=$1 run=$2 model=$3 out=$4 subjects=${5:-80}
py=/usr/bin/python3
here=$(dirname "$0")
[ -f "$model" ] || { echo "bareskin_skin_tone: $model is missing (mm-build's model, e.g. out/demo/model/model.safetensors)" >&2; exit 3; }
mkdir -p "$out"
if [ ! -f "$out/faces/test/manifest.json" ]; then
  "$bin/bareskin" -q --threads 2 texgen faces --model "$model" --mm-subjects $((subjects + 1)) --skin-tones balanced \
    --val 0 --test "$subjects" --count $(((subjects + 1) * 10)) --seed 99 --align truth -o "$out/faces"
fi
[ -d "$out/photos" ] || { $py "$here/bareskin_skin_tone.py" extract "$out/faces" "$out/photos.tmp" && mv "$out/photos.tmp" "$out/photos"; }
"$bin/bareskin" -q --threads 2 demakeup "$out/photos" --aligned --run "$run" -o "$out/demakeup" --uv-size 64 --keep-going
$py "$here/bareskin_skin_tone.py" report "$out/faces" "$out/demakeup" --json "$out/skin_tone.json" | tee "$out/skin_tone.md"
