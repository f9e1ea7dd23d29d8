#!/usr/bin/env bash
# The inputs of the `makeup apply` / `relight` speed figures (bench/BENCHMARKS.md, "Makeup on an avatar,
# relighting"): the default 65k template, and two avatar folders with its mesh and oiiotool noise maps (noise is the
# worst case for PNG): OUT/a1k with 1K maps, OUT/a4k with the same 1K maps plus 4K _hr maps. Each folder is read once,
# so that it holds its mesh cache (mesh.obj.cache) before anything is timed.
# Usage: bench/makeup_speed_inputs.sh [build/bin] [OUT]   (then BARESKIN_TEMPLATE=OUT/t65 for the timed commands)
set -euo pipefail
bin=${1:-build/bin}
out=${2:-out/makeup_speed}
mkdir -p "$out"
[ -d "$out/t65" ] || "$bin/bareskin" template -q -o "$out/t65"
maps() {  # maps DIR SIZE SUFFIX
  local d=$1/maps n=$2 s=$3
  mkdir -p "$d"
  oiiotool --pattern noise:type=uniform:min=0.6:max=0.7 "${n}x${n}" 3 --mulc 1,0.8,0.7 -d uint8 -o "$d/diffuse$s.png"
  oiiotool --pattern noise:type=uniform:min=0.45:max=0.55 "${n}x${n}" 3 --addc 0,0,0.45 -d uint8 -o "$d/normal$s.png"
  oiiotool --pattern noise:type=uniform:min=0.4:max=0.6 "${n}x${n}" 1 -d uint8 -o "$d/roughness$s.png"
  oiiotool --pattern noise:type=uniform:min=0.2:max=0.3 "${n}x${n}" 1 -d uint8 -o "$d/specular$s.png"
}
for a in a1k a4k; do
  mkdir -p "$out/$a"
  cp "$out/t65/face.obj" "$out/$a/mesh.obj"
  maps "$out/$a" 1024 ""
done
maps "$out/a4k" 4096 _hr
for a in a1k a4k; do
  BARESKIN_TEMPLATE=$out/t65 "$bin/bareskin" relight -q "$out/$a" --direction 0,0,1 --size 64 -o "$out/$a.warm.png"
  rm "$out/$a.warm.png"
done
echo "inputs in $out: BARESKIN_TEMPLATE=$out/t65 bareskin makeup apply --threads 2 $out/a1k --look glam -o OUT"
