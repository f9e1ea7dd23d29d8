#!/usr/bin/env bash
# uvtools bake vs oiiotool, side by side in one run, on a 16384² RGB half EXR diffuse map in the template UV (the demo's
# transferred 1K diffuse upsampled, plus Gaussian noise so it compresses like real skin detail).
# Ours writes 4K and 1K from one read; oiiotool (`--resize:filter=box 4096x4096`) writes 4K only.
# Prints wall time and peak RSS of both, the ratio, and the PSNR of our 4K against oiiotool's inside the UV islands.
# Usage: bench/uvtools_bake.sh [build/bin] [template dir] [demo registered subject dir] [size]
set -euo pipefail
bin=${1:-build/bin}
template=${2:-out/demo/template}
subject=${3:-out/demo/registered/subject_0000}
size=${4:-16384}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/in"
oiiotool "$subject/diffuse.png" --colorconvert sRGB linear --resize "${size}x${size}" \
  --pattern "noise:type=gaussian:mean=0:stddev=0.02" "${size}x${size}" 3 --add -d half --compression zip \
  -o "$work/in/diffuse.exr"
measure() {  # measure NAME command...: prints "NAME seconds peak_mb"
  local name=$1
  shift
  /usr/bin/time -f "%e %M" -o "$work/t_$name" "$@" > /dev/null 2>&1
  read -r s kb < "$work/t_$name"
  echo "$s $((kb / 1024))"
}
read -r ours_s ours_mb < <(measure ours "$bin/bareskin" uvtools bake -q "$work/in" -o "$work/ours" --sizes 4096,1024 \
  --format exr --layout "$template/face.obj")
read -r oiio_s oiio_mb < <(measure oiio oiiotool "$work/in/diffuse.exr" --resize:filter=box 4096x4096 -o "$work/oiio.exr")
psnr=$(/usr/bin/python3 - "$(dirname "$0")/../tests/python" "$template/face.obj" "$work/ours/4096/diffuse.exr" "$work/oiio.exr" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import island_mask, read
mask = island_mask(sys.argv[2], 4096)
inside = mask.copy()  # texels whose 3x3 neighbourhood is inside: their 16K footprint is inside the islands
for dy in (-1, 0, 1):
    for dx in (-1, 0, 1):
        inside &= np.roll(np.roll(mask, dy, 0), dx, 1)
a, b = read(sys.argv[3])[..., :3], read(sys.argv[4])[..., :3]
mse = ((a - b)[inside] ** 2).mean()
print(f"{10 * np.log10(1 / max(mse, 1e-20)):.1f} dB over {inside.sum()} texels")
PY
)
echo "input ${size}² RGB half EXR (zip), $(nproc) cores"
printf "%-44s %8s s %7s MB\n" "ours: uvtools bake --sizes 4096,1024" "$ours_s" "$ours_mb"
printf "%-44s %8s s %7s MB\n" "oiiotool --resize:filter=box 4096x4096" "$oiio_s" "$oiio_mb"
echo "ratio ours/oiiotool: time $(/usr/bin/python3 -c "print(f'{$ours_s / $oiio_s:.2f}')"), peak memory $(/usr/bin/python3 -c "print(f'{$ours_mb / $oiio_mb:.2f}')")"
echo "our 4K vs oiiotool's inside the islands: PSNR $psnr"
