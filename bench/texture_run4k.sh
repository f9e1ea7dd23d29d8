#!/usr/bin/env bash
# `bareskin run` at 4K output on the 2-core CPU: skimage's astronaut through G + F, pix2pixHD (ngf 16, 3 downsamplings,
# 3 blocks) at 1K, MSRResNet 16 x 4 blocks x4 to 4K for the --sr-maps (the others bicubic), the whole avatar folder
# written. The nets are 1-step runs at full size (their speed is the trained nets'; their noisy maps are the PNG
# encoder's worst case), made once under <work>/nets from the demo's texture shards. Prints per run the wall and CPU
# seconds (user + sys) and the stages' wall/CPU seconds from report.json, then the medians.
# Usage: bash bench/texture_run4k.sh <bin dir> <demo out folder> <work dir> [runs (3)] [sr-maps (diffuse,roughness,specular)]
set -euo pipefail
bin=${1:-build/bin}; demo=${2:-out/demo}; work=${3:-out/bench_run4k}; runs=${4:-3}
sr_maps=${5:-diffuse,roughness,specular}
bareskin="$bin/bareskin"; model="$demo/model/model.safetensors"; nets="$work/nets"
photo=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
mkdir -p "$nets"
if [ ! -f "$nets/tex/checkpoint.safetensors" ]; then
  "$bareskin" -q --threads 2 train texture --data "$demo/texture_data/train" --model "$model" -o "$nets/tex" --res 1024 \
    --steps 1 --batch 1 --generator '{"ngf": 16, "n_downsampling": 3, "n_blocks": 3}' \
    --discriminator '{"ndf": 16, "n_layers": 2}' --lambda-perceptual 0 --lambda-l1 10 --checkpoint-every 1
fi
ups=()
for map in diffuse normal roughness specular; do
  if [ ! -f "$nets/up_$map/checkpoint.safetensors" ]; then
    "$bareskin" -q --threads 2 train upscale --map "$map" --phase l1 --data "$demo/texture_data/train" --model "$model" \
      -o "$nets/up_$map" --steps 1 --batch 1 --pool 1 --generator '{"num_feat": 16, "num_block": 4}' --checkpoint-every 1
  fi
  ups+=("$nets/up_$map")
done
bsn=$(ls -d "$demo"/bareskinnet/run); recon=$(ls -d "$demo"/recon/F)
for i in $(seq 1 "$runs"); do
  rm -rf "$work/avatar_$i"
  /usr/bin/time -o "$work/time_$i.txt" -f "%e %U %S" "$bareskin" -q --threads 2 run "$photo" -o "$work/avatar_$i" \
    --model "$model" --texture "$nets/tex" --upscale "${ups[@]}" --bareskin "$bsn" --teacher "$recon" --sr-maps "$sr_maps"
done
python3 - "$work" "$runs" "$sr_maps" <<'PY'
import json, statistics, sys
work, runs, sr = sys.argv[1], int(sys.argv[2]), sys.argv[3]
walls, cpus, stages = [], [], {}
print(f"bareskin run at 4K, --sr-maps {sr}: stage wall/CPU s")
for i in range(1, runs + 1):
    wall, user, sys_ = map(float, open(f"{work}/time_{i}.txt").read().split()[-3:])
    r = json.load(open(f"{work}/avatar_{i}/report.json"))
    walls.append(wall); cpus.append(user + sys_)
    for k in r["seconds"]:
        stages.setdefault(k, []).append((r["seconds"][k], r["cpu_seconds"][k]))
    line = " ".join(f"{k} {r['seconds'][k]:.2f}/{r['cpu_seconds'][k]:.2f}" for k in sorted(r["seconds"]))
    print(f"run {i}: wall {wall:.1f} s, CPU {user + sys_:.1f} s (load {r['load_seconds']:.1f} s wall); {line}")
print(f"median: wall {statistics.median(walls):.1f} s, CPU {statistics.median(cpus):.1f} s; " +
      " ".join(f"{k} {statistics.median(w for w, _ in v):.2f}/{statistics.median(c for _, c in v):.2f}"
               for k, v in sorted(stages.items())))
PY
