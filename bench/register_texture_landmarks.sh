#!/usr/bin/env bash
# Texture landmarks (`scan register --texture-landmarks N`, bench/BENCHMARKS.md "Texture landmarks") on the six
# held-out noisy scans of bench/register_heldout.sh, side by side with the detected landmarks alone and with the
# true landmarks restricted to the same points (what perfect texture landmarks could give); and the outline term
# (`--outline-weight`: these scans are cut along the template's face outline) alone and with them; last, the rounds'
# speed against accuracy (OUT/rounds.csv, OUT/rounds.png: bench/register_texture_landmarks_rounds.png is its copy).
# Usage: bench/register_texture_landmarks.sh BIN TEMPLATE DEMO_SCANS OUT
#   DEMO_SCANS: the demo's scans: subjects 0-4 calibrate the detector, all ten registered (true landmarks, maps at
#   512) make the reference, the mean of their diffuse maps (none of the six held-out subjects is among them).
# Cached under OUT like the scripts it calls; the table is the last thing printed. THREADS as in register_heldout.sh.
set -euo pipefail
bin=$1 template=$2 demo_scans=$3 out=$4
# shellcheck source=bench/register_common.sh
source "$(dirname "$0")/register_common.sh"
here=$(cd "$(dirname "$0")" && pwd)
MODEL30=0 bash "$here/register_heldout.sh" "$bin" "$template" "$demo_scans" "$out"
ref=$(texture_reference "$bin" "$template" "$demo_scans" "$out")
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

# The rounds' size knob (speed against accuracy): detected landmarks with the outline term and 0-4 texture-landmark
# rounds (0: the outline alone). Accuracy over the six scans; time of one scan registered alone (det_n01 subject 0,
# --threads 2, report.json's total, the faster of two runs, the settings alternated: the folder rows above register
# two scans at a time). Chart: OUT/rounds.png.
cat > "$out/rounds.variants" <<VARIANTS
outline_alone|--outline-weight 0.3
outline_rounds_1|--texture-reference $ref --texture-landmarks 1 --outline-weight 0.3
texture_landmarks_2_outline|--texture-reference $ref --texture-landmarks 2 --outline-weight 0.3
outline_rounds_3|--texture-reference $ref --texture-landmarks 3 --outline-weight 0.3
outline_rounds_4|--texture-reference $ref --texture-landmarks 4 --outline-weight 0.3
VARIANTS
bash "$here/register_variants.sh" "$bin" "$template" "$out/variants" "$out/rounds.variants" \
    detected=$out/det_n01 detected=$out/det_n03 >/dev/null
lone=$out/rounds_lone && mkdir -p "$lone/scan" && ln -sfn "$(cd "$out/det_n01/subject_0000" && pwd)" "$lone/scan/subject_0000"
for run in a b; do
  for n in anchor 0 1 2 3 4; do
    case $n in
      anchor) flags="" ;;
      0) flags="--outline-weight 0.3" ;;
      *) flags="--outline-weight 0.3 --texture-reference $ref --texture-landmarks $n" ;;
    esac
    # shellcheck disable=SC2086  # flags hold several flags
    [ -d "$lone/$n$run" ] || "$bin/bareskin" -q --threads 2 scan register --template "$template" --scans "$lone/scan" \
        -o "$lone/$n$run" --maps-res 0 $detected_schedule $flags
  done
done
/usr/bin/python3 - "$out" > "$out/rounds.csv" <<'PY'
import glob, json, statistics as st, sys
out = sys.argv[1]
rows = {"anchor": "detected_alone", 0: "outline_alone", 1: "outline_rounds_1", 2: "texture_landmarks_2_outline",
        3: "outline_rounds_3", 4: "outline_rounds_4"}
for n, name in rows.items():
    reps = [json.load(open(p)) for p in sorted(glob.glob(f"{out}/variants/{name}/detected_*/subject_*/report.json"))]
    med = st.median(r["correspondence_error_mm"]["median"] for r in reps)
    p95 = st.median(r["correspondence_error_mm"]["p95"] for r in reps)
    seconds = min(json.load(open(f"{out}/rounds_lone/{n}{run}/subject_0000/report.json"))["seconds"]["total"]
                  for run in "ab")
    label = ("anchor: NICP alone" if n == "anchor" else f"{n} round{'' if n == 1 else 's'}" +
             (" (the outline alone)" if n == 0 else " (recommended)" if n == 2 else ""))
    print(f'"{label}",0,{med},{p95},{seconds}')
PY
cat "$out/rounds.csv"
/usr/bin/python3 "$here/register_chart.py" "$out/rounds.csv" "$out/rounds.png" \
    "scan register --texture-landmarks N --outline-weight 0.3, detected landmarks,\n6 held-out noisy scans (dashed: 0.6 mm goal; dotted: 10 s; star: recommended)" \
    "seconds for one scan registered alone (2 threads)" 0.6
