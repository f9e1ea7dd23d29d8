#!/usr/bin/env bash
# The texture half of the CPU reference (after bench/cpu_reference.sh's G): texture inference trained and scored on a
# world of its own, on held-out subjects.
#   1. a texture world: `scan synth` subjects (the demo's template and generator settings, another seed) "registered"
#      from their truth (tests/python/truth_registered.py: the template on the true correspondence, the true maps in
#      the template UV), then `texgen make-dataset` (the diffuse-only unwrap, what BareSkinNet hands over), split by
#      subject 80/10/10;
#   2. pix2pixHD and the UV net (`train texture --profile cpu`) on both unwraps, SRGAN x4 on the diffuse,
#      roughness and specular, scored against the 3DMM-only maps and bicubic;
#   3. Table 1 (`bareskin evaluate`) on faces with makeup of the test subjects, with the G of bench/cpu_reference.sh.
# Every stage is skipped when its output exists; trainings continue with --resume.
#   bash bench/cpu_reference_texture.sh <bin/> <demo out/> <out/> [subjects]
set -euo pipefail
bin=$1 demo=$2 out=$3 subjects=${4:-60}
bareskin="$bin/bareskin"
here=$(cd "$(dirname "$0")" && pwd)
py=/usr/bin/python3
model="$demo/model/model.safetensors"
[ -f "$model" ] || { echo "cpu_reference_texture: $model is missing; run 'make demo' first (it builds the model)" >&2; exit 3; }
mkdir -p "$out"
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-PASSIVE} BARESKIN_TEMPLATE=${BARESKIN_TEMPLATE:-$demo/template}
cpu() {  # cpu NAME command...: runs it, appends NAME and its CPU seconds (user + system) to $out/cpu.txt
  local name=$1
  shift
  /usr/bin/time -f "$name %U %S %e" -a -o "$out/cpu.txt" "$@"
}

# 1. The world ------------------------------------------------------------------------------------------------------
if [ ! -f "$out/scans/manifest.json" ]; then
  echo "cpu_reference_texture: scan synth ($subjects subjects)" >&2
  cpu synth "$bareskin" -q --threads 2 scan synth --template "$demo/template" --count "$subjects" --seed 101 \
    --vertices 20000 --res 256 --truth-res 1024 --holes -o "$out/scans.tmp"
  rm -rf "$out/scans" && mv "$out/scans.tmp" "$out/scans"
fi
if [ ! -f "$out/registered/.complete" ]; then
  $py "$here/../tests/python/truth_registered.py" "$demo/template/face.obj" "$out/scans" "$out/registered" "*.png"
  touch "$out/registered/.complete"
fi
data="$out/data"
if [ ! -f "$data/test/manifest.json" ] || ! grep -q '"complete": true' "$data/test/manifest.json"; then
  echo "cpu_reference_texture: texgen make-dataset" >&2
  cpu data "$bareskin" -q --threads 2 texgen make-dataset "$out/registered" --model "$model" -o "$data" \
    --render-size 512 --input-res 256 --target-res 256 --hr-res 1024 --masks 3 --split 0.8,0.1,0.1 --seed 3
fi
