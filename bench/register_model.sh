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
# shellcheck source=bench/register_common.sh
source "$(dirname "$0")/register_common.sh"
for spec in "$@"; do
  kind=${spec%%=*} scans=${spec#*=}
  name=$(basename "$scans")
  flags=""
  [ "$kind" = detected ] && flags=$detected_schedule
  # shellcheck disable=SC2086  # flags and MODEL_FLAGS hold several flags
  register_into "$bin" "$template" "$scans" "$out/before_${kind}_$name" $flags
  # shellcheck disable=SC2086
  register_into "$bin" "$template" "$scans" "$out/after_${kind}_$name" $flags --model "$model" ${MODEL_FLAGS:-}
done
register_table "$out" <<'PY'
import json, os, sys
from register_table import table

def row(kind, before_path, b):
    after_path = before_path.replace(f"/before_{kind}_", f"/after_{kind}_")
    if not os.path.exists(after_path):
        return None
    a = json.load(open(after_path))
    fit = a["model_prior"].get("correspondence_error_after_fit_mm", {}).get("median", float("nan"))
    return (b["correspondence_error_mm"]["median"], a["correspondence_error_mm"]["median"],
            b["correspondence_error_mm"]["p95"], a["correspondence_error_mm"]["p95"], fit,
            b["seconds"]["total"], a["seconds"]["total"])

table(sys.argv[1], "before_", [[("median before", 13, 3, 0), ("after", 6, 3, 1)],
                               [("p95 before", 10, 3, 2), ("after", 6, 3, 3)], [("fit alone", 9, 3, 4)],
                               [("s/scan before", 13, 1, 5), ("after", 6, 1, 6)]], row, 24)
PY
