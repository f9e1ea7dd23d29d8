#!/usr/bin/env bash
# scan register with the model prior (--model) against the synthetic truth, before (no model) | after, per scan and as
# medians over the scans: correspondence median and p95, the model fit's own error (before NICP), seconds per scan.
# Usage: bench/register_model.sh BIN TEMPLATE OUT MODEL KIND=SCANS_DIR...
#   KIND is "true" (the scans' own landmarks.json) or "detected": a copy of the scans whose landmarks.json holds the
#   detector's points (calibrated multi-view, e.g. a run's landmarks_detected.json), registered with the schedule
#   scan register uses for detected points (landmark weight 10 -> 0). The scans must be held out of MODEL's population.
# Extra flags for the "after" runs in MODEL_FLAGS (e.g. "--model-regularisation 0.1"), for both in REGISTER_FLAGS.
# Rows are cached in OUT (delete a row's folder to rerun it).
set -euo pipefail
bin=$1 template=$2 out=$3 model=$4
shift 4
mkdir -p "$out"
detected_weights="--landmark-weight 10 3.33333 1.11111 0 0 0"
for spec in "$@"; do
  kind=${spec%%=*} scans=${spec#*=}
  name=$(basename "$scans")
  flags=""
  [ "$kind" = detected ] && flags=$detected_weights
  [ -d "$out/before_${kind}_$name" ] || nice "$bin/bareskin" scan register -q --template "$template" --scans "$scans" \
      -o "$out/before_${kind}_$name" --maps-res 0 $flags ${REGISTER_FLAGS:-}
  [ -d "$out/after_${kind}_$name" ] || nice "$bin/bareskin" scan register -q --template "$template" --scans "$scans" \
      -o "$out/after_${kind}_$name" --maps-res 0 $flags --model "$model" ${MODEL_FLAGS:-} ${REGISTER_FLAGS:-}
done
/usr/bin/python3 - "$out" <<'PY'
import glob, json, os, statistics as st, sys
out = sys.argv[1]
print(f"{'landmarks':<9} {'scan':<24} | {'median before':>13} {'after':>6} | {'p95 before':>10} {'after':>6} | "
      f"{'fit alone':>9} | {'s/scan before':>13} {'after':>6}")
for kind in ("true", "detected"):
    rows = []
    for before_path in sorted(glob.glob(f"{out}/before_{kind}_*/subject_*/report.json")):
        after_path = before_path.replace(f"/before_{kind}_", f"/after_{kind}_")
        if not os.path.exists(after_path):
            continue
        b, a = json.load(open(before_path)), json.load(open(after_path))
        fit = a["model_prior"].get("correspondence_error_after_fit_mm", {}).get("median", float("nan"))
        row = (b["correspondence_error_mm"]["median"], a["correspondence_error_mm"]["median"],
               b["correspondence_error_mm"]["p95"], a["correspondence_error_mm"]["p95"], fit,
               b["seconds"]["total"], a["seconds"]["total"])
        rows.append(row)
        scan = before_path.split("/")[-3].split("_", 2)[2] + "/" + before_path.split("/")[-2]
        print(f"{kind:<9} {scan:<24} | {row[0]:13.3f} {row[1]:6.3f} | {row[2]:10.3f} {row[3]:6.3f} | {row[4]:9.3f} | "
              f"{row[5]:13.1f} {row[6]:6.1f}")
    if rows:
        m = [st.median(c) for c in zip(*rows)]
        print(f"{kind:<9} {'MEDIAN of ' + str(len(rows)) + ' scans':<24} | {m[0]:13.3f} {m[1]:6.3f} | {m[2]:10.3f} "
              f"{m[3]:6.3f} | {m[4]:9.3f} | {m[5]:13.1f} {m[6]:6.1f}")
PY
