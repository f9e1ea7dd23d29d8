#!/usr/bin/env bash
# The data of the registration benches (bench/BENCHMARKS.md, "Model prior", "σ-weighted landmarks"): six held-out noisy
# `scan synth` scans with their detected (calibrated 16-view) landmarks, and a 30-subject model none of them is in.
# Usage: bench/register_heldout.sh BIN TEMPLATE DEMO_SCANS OUT
#   DEMO_SCANS: the demo's scans (subjects 0-4 calibrate the detector). Writes under OUT:
#   scans_n01, scans_n03   three scans each (--holes --res 1024; noise 0.1 mm seed 31, noise 0.3 mm seed 32), true landmarks
#   calib16.json           `landmarks calibrate --count 5` on DEMO_SCANS
#   det_n01, det_n03       the same scans (hard links) whose landmarks.json is `landmarks scan --views 16 --calibration`
#                          (with per-point sigma_mm); nosigma_n01, nosigma_n03: the same points without "detail"
#   model30/model.safetensors  30 `scan synth` subjects (--seed 101 --holes --res 0) registered from their true
#                          landmarks, then mm-build --appearance-components 0
# Every step is skipped when its output exists. THREADS (default 2) is passed to bareskin. SEEDS (default "31 32"): the
# two sets' scan synth seeds (bench/register_shape_points.sh makes a second held-out set with "51 52"). MODEL30=0
# skips the model (30 synthetic subjects at 100k vertices plus their registrations: most of the time on a loaded
# 2-core machine).
set -euo pipefail
bin=$1 template=$2 demo_scans=$3 out=$4
bs() { nice "$bin/bareskin" -q --threads "${THREADS:-2}" "$@"; }
mkdir -p "$out"
read -r -a seeds <<<"${SEEDS:-31 32}"  # the noise-0.1 and the noise-0.3 set's seeds
for spec in "n01:0.1:${seeds[0]}" "n03:0.3:${seeds[1]}"; do
  IFS=: read -r name noise seed <<<"$spec"
  [ -d "$out/scans_$name" ] || bs scan synth --template "$template" -o "$out/scans_$name" --count 3 --seed "$seed" \
      --noise "$noise" --holes --res 1024
done
[ -f "$out/calib16.json" ] || bs landmarks calibrate --scans "$demo_scans" -o "$out/calib16.json" --views 16 --count 5
for name in n01 n03; do
  for s in "$out/scans_$name"/subject_*; do
    id=$(basename "$s") det="$out/det_$name/$(basename "$s")" nosig="$out/nosigma_$name/$(basename "$s")"
    if [ ! -f "$det/landmarks.json" ]; then
      mkdir -p "$det"
      for f in "$s"/*; do [ "$(basename "$f")" = landmarks.json ] || cp -al "$f" "$det/"; done
      bs landmarks scan "$s" -o "$det/landmarks.json.tmp" --views 16 --calibration "$out/calib16.json"
      mv "$det/landmarks.json.tmp" "$det/landmarks.json"
    fi
    if [ ! -f "$nosig/landmarks.json" ]; then
      mkdir -p "$nosig"
      for f in "$det"/*; do [ "$(basename "$f")" = landmarks.json ] || cp -al "$f" "$nosig/"; done
      /usr/bin/python3 -c "import json,sys; d=json.load(open(sys.argv[1])); d.pop('detail',None); json.dump(d,open(sys.argv[2],'w'))" \
          "$det/landmarks.json" "$nosig/landmarks.json"
    fi
    echo "$id ($name) detected: $(/usr/bin/python3 - "$det/landmarks.json" "$s/landmarks.json" <<'PY'
import json, sys, statistics as st
d, t = (json.load(open(p)) for p in sys.argv[1:3])
e = [sum((a - b) ** 2 for a, b in zip(p, q)) ** 0.5 for p, q in zip(d["points"], t["points"]) if p]
print(f"median {st.median(e):.2f} mm from the truth over {len(e)} points")
PY
)"
  done
done
if [ "${MODEL30:-1}" != 0 ] && [ ! -f "$out/model30/model.safetensors" ]; then
  [ -d "$out/pop30" ] || bs scan synth --template "$template" -o "$out/pop30" --count 30 --seed 101 --holes --res 0
  bs scan register --template "$template" --scans "$out/pop30" -o "$out/pop30_registered" --maps-res 0
  bs mm-build --template "$template" --registered "$out/pop30_registered" -o "$out/model30/model.safetensors" \
      --appearance-components 0
fi
