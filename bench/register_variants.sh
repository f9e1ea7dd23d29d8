#!/usr/bin/env bash
# scan register settings side by side on the held-out scans of bench/register_heldout.sh: per setting the median over
# the scans of the per-scan correspondence median and p95, for detected and for true landmarks, and the per-scan medians.
# Usage: bench/register_variants.sh BIN TEMPLATE OUT VARIANTS KIND=SCANS_DIR...
#   VARIANTS: a file of lines "name|scan register flags" (# comments). KIND: "true" (the scans' own landmarks.json,
#   default schedule) or "detected" (a landmarks.json from the detector, registered with the detected-landmark schedule,
#   landmark weight 10 -> 0, unless the variant gives --landmark-weight). All rows run with --maps-res 0 and
#   REGISTER_FLAGS. Cached: OUT/<name>/<kind>_<scans folder>/ (delete it to rerun).
set -euo pipefail
bin=$1 template=$2 out=$3 variants=$4
shift 4
# shellcheck source=bench/register_common.sh
source "$(dirname "$0")/register_common.sh"
while IFS='|' read -r name flags; do
  [[ -z "$name" || "$name" == \#* ]] && continue
  for spec in "$@"; do
    kind=${spec%%=*} scans=${spec#*=}
    schedule=""
    [[ "$kind" = detected && "$flags" != *--landmark-weight* ]] && schedule=$detected_schedule
    # shellcheck disable=SC2086  # flags hold several flags
    register_into "$bin" "$template" "$scans" "$out/$name/${kind}_$(basename "$scans")" $schedule $flags </dev/null
  done
done <"$variants"
/usr/bin/python3 - "$out" "$variants" <<'PY'
import glob, json, statistics as st, sys
out, variants = sys.argv[1], sys.argv[2]
names = [l.split("|")[0].strip() for l in open(variants) if l.strip() and not l.startswith("#")]
print(f"{'setting':<28} | {'detected median':>15} {'p95':>6} | {'true median':>11} {'p95':>6} | {'fit alone d/t':>13} | per-scan detected medians")
for name in names:
    cols = {}
    for kind in ("detected", "true"):
        reps = [json.load(open(p)) for p in sorted(glob.glob(f"{out}/{name}/{kind}_*/subject_*/report.json"))]
        med = [r["correspondence_error_mm"]["median"] for r in reps]
        p95 = [r["correspondence_error_mm"]["p95"] for r in reps]
        fit = [r["model_prior"]["correspondence_error_after_fit_mm"]["median"] for r in reps if "model_prior" in r]
        cols[kind] = (st.median(med) if med else float("nan"), st.median(p95) if p95 else float("nan"),
                      st.median(fit) if fit else float("nan"), med)
    d, t = cols["detected"], cols["true"]
    print(f"{name:<28} | {d[0]:15.3f} {d[1]:6.3f} | {t[0]:11.3f} {t[1]:6.3f} | {d[2]:6.2f}/{t[2]:6.2f} | "
          + " ".join(f"{v:.2f}" for v in d[3]))
PY
