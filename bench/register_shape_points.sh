#!/usr/bin/env bash
# Shape points (`scan register --shape-points N --shape-point-weight W`, bench/BENCHMARKS.md "Shape points"): the
# texture-landmark rounds with and without them, from detected landmarks, on two held-out sets of six noisy, holed
# `scan synth` scans: the set the weight was chosen on (bench/register_heldout.sh, seeds 31 32) and a second one made
# only to check it (seeds 51 52). Then the size knob on the first set: accuracy over the six scans and the time of one
# scan registered alone, for 0-4000 points (OUT/shape_points.csv, OUT/shape_points.png).
# Usage: bench/register_shape_points.sh BIN TEMPLATE DEMO_SCANS OUT
#   DEMO_SCANS: the demo's scans: subjects 0-4 calibrate the detector, all ten registered (true landmarks, maps at
#   512) make the texture reference (none of the twelve held-out subjects is among them).
# Cached under OUT like the scripts it calls; the tables are printed last. THREADS as in register_heldout.sh.
set -euo pipefail
bin=$1 template=$2 demo_scans=$3 out=$4
# shellcheck source=bench/register_common.sh
source "$(dirname "$0")/register_common.sh"
here=$(cd "$(dirname "$0")" && pwd)
MODEL30=0 bash "$here/register_heldout.sh" "$bin" "$template" "$demo_scans" "$out"
mkdir -p "$out/check" && ln -sf ../calib16.json "$out/check/calib16.json"
SEEDS="51 52" MODEL30=0 bash "$here/register_heldout.sh" "$bin" "$template" "$demo_scans" "$out/check"
ref=$(texture_reference "$bin" "$template" "$demo_scans" "$out")
rounds() { echo "--texture-reference $ref --texture-landmarks $1 --outline-weight 0.3"; }
cat > "$out/shape_points.variants" <<VARIANTS
detected_alone|
rounds_2_without|$(rounds 2) --shape-points 0
rounds_2|$(rounds 2)
rounds_3_without|$(rounds 3) --shape-points 0
rounds_3|$(rounds 3)
VARIANTS
cat > "$out/knob.variants" <<VARIANTS
shape_500|$(rounds 3) --shape-points 500
shape_1000|$(rounds 3) --shape-points 1000
shape_4000|$(rounds 3) --shape-points 4000
VARIANTS
for set in "$out" "$out/check"; do
  bash "$here/register_variants.sh" "$bin" "$template" "$set/variants" "$out/shape_points.variants" \
      detected="$set/det_n01" detected="$set/det_n03" >"$set/shape_points.txt"
done
bash "$here/register_variants.sh" "$bin" "$template" "$out/variants" "$out/knob.variants" \
    detected="$out/det_n01" detected="$out/det_n03" >/dev/null

# The knob: 3 rounds with 0-4000 shape points; time of det_n01 subject 0 registered alone (--threads 2, report.json's
# total, the faster of two alternated runs).
lone=$out/lone && mkdir -p "$lone/scan" && ln -sfn "$(cd "$out/det_n01/subject_0000" && pwd)" "$lone/scan/subject_0000"
for run in a b; do
  for n in 0 500 1000 2000 4000; do
    # shellcheck disable=SC2046  # rounds gives several flags
    [ -d "$lone/$n$run" ] || "$bin/bareskin" -q --threads 2 scan register --template "$template" --scans "$lone/scan" \
        -o "$lone/$n$run" --maps-res 0 --landmark-weight 10 3.33333 1.11111 0 0 0 $(rounds 3) --shape-points "$n"
  done
done
/usr/bin/python3 - "$out" > "$out/shape_points.csv" <<'PY'
import glob, json, statistics as st, sys
out = sys.argv[1]
rows = {0: "rounds_3_without", 500: "shape_500", 1000: "shape_1000", 2000: "rounds_3", 4000: "shape_4000"}
for n, name in rows.items():
    reps = [json.load(open(p)) for p in sorted(glob.glob(f"{out}/variants/{name}/detected_*/subject_*/report.json"))]
    med = st.median(r["correspondence_error_mm"]["median"] for r in reps)
    p95 = st.median(r["correspondence_error_mm"]["p95"] for r in reps)
    seconds = min(json.load(open(f"{out}/lone/{n}{run}/subject_0000/report.json"))["seconds"]["total"] for run in "ab")
    label = f"{n} shape points" + (" (recommended)" if n == 2000 else "")
    print(f'"{label}",0,{med},{p95},{seconds}')
PY
/usr/bin/python3 - "$out/shape_points.csv" "$out/shape_points.png" <<'PY'
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
rows = list(csv.reader(open(sys.argv[1])))
n = [int(r[0].split()[0]) for r in rows]
med, p95, sec = ([float(r[k]) for r in rows] for k in (2, 3, 4))
x = range(len(n))
fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
a.bar(x, p95, color="C0", alpha=0.3, label="p95")
a.bar(x, med, color="C0", label="median")
a.axhline(0.6, ls="--", color="gray", label="0.6 mm goal (median)")
b.bar(x, sec, color="C1")
for ax, title in ((a, "correspondence error, mm (6 held-out scans)"), (b, "seconds, one scan registered alone")):
    ax.set_xticks(list(x), [f"{k}" + (" *" if k == 2000 else "") for k in n])
    ax.set_xlabel("--shape-points (* recommended)")
    ax.set_title(title, fontsize=10)
a.legend(fontsize=8)
fig.suptitle("scan register --texture-landmarks 3 --outline-weight 0.3 from detected landmarks")
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=100)
PY
echo "== the set the weight was chosen on (seeds 31 32)"; cat "$out/shape_points.txt"
echo "== the check set (seeds 51 52)"; cat "$out/check/shape_points.txt"
echo "== the knob (first set, 3 rounds)"; cat "$out/shape_points.csv"
