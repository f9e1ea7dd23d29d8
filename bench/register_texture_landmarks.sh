#!/usr/bin/env bash
# Texture landmarks (`scan register --texture-landmarks N`, bench/BENCHMARKS.md "Texture landmarks") on the six
# held-out noisy scans of bench/register_heldout.sh, side by side with the detected landmarks alone and with the
# true landmarks restricted to the same points (what perfect texture landmarks could give); and the outline term
# (`--outline-weight`: these scans are cut along the template's face outline) alone and with them.
# Usage: bench/register_texture_landmarks.sh BIN TEMPLATE DEMO_SCANS OUT
#   DEMO_SCANS: the demo's scans: subjects 0-4 calibrate the detector, all ten registered (true landmarks, maps at
#   512) make the reference, the mean of their diffuse maps (none of the six held-out subjects is among them).
# Cached under OUT like the scripts it calls; the table is the last thing printed. THREADS as in register_heldout.sh.
set -euo pipefail
bin=$1 template=$2 demo_scans=$3 out=$4
here=$(cd "$(dirname "$0")" && pwd)
MODEL30=0 bash "$here/register_heldout.sh" "$bin" "$template" "$demo_scans" "$out"
[ -d "$out/reference_registered" ] || nice "$bin/bareskin" -q scan register --template "$template" \
    --scans "$demo_scans" -o "$out/reference_registered" --maps-res 512
[ -f "$out/reference512.png" ] || /usr/bin/python3 "$here/register_texture_reference.py" "$out/reference512.png" \
    "$out/reference_registered"/subject_*/diffuse.png
ref=$(cd "$out" && pwd)/reference512.png
features=$(echo $(seq 17 26) $(seq 36 59))
cat > "$out/texture_landmarks.variants" <<VARIANTS
detected_alone|
texture_landmarks_1|--texture-reference $ref --texture-landmarks 1
texture_landmarks_2|--texture-reference $ref --texture-landmarks 2
outline_alone|--outline-weight 0.3
texture_landmarks_2_outline|--texture-reference $ref --texture-landmarks 2 --outline-weight 0.3
true_34_features_only|--landmark-ids $features
VARIANTS
bash "$here/register_variants.sh" "$bin" "$template" "$out/variants" "$out/texture_landmarks.variants" \
    detected=$out/det_n01 detected=$out/det_n03 true=$out/scans_n01 true=$out/scans_n03
