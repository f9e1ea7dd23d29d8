#!/usr/bin/env bash
# scan register --texture-refine N against the synthetic truth: the correspondence error of each scan before the
# texture refinement (the NICP result, report.json's texture_refine.correspondence_error_before_mm) and after it, side
# by side with the ratio, from the scans' true landmarks and from detected (calibrated multi-view) landmarks.
# Usage: bench/register_texture.sh BIN TEMPLATE REFERENCE.png OUT CALIBRATION.json ROUNDS SCANS_DIR...
#   REFERENCE.png: the template-UV reference (`bareskin uvtools mean` over OTHER scans' registered
#   diffuse.png); CALIBRATION.json: `landmarks calibrate` on other scans ("" skips the detected-landmark rows).
# Extra `scan register` flags can be given in REGISTER_FLAGS. Rows are cached in OUT (delete it to rerun).
set -euo pipefail
bin=$1 template=$2 reference=$3 out=$4 calibration=$5 rounds=$6
shift 6
mkdir -p "$out"
# shellcheck source=bench/register_common.sh
source "$(dirname "$0")/register_common.sh"
texture=(--texture-refine "$rounds" --texture-reference "$reference")
for scans in "$@"; do
  name=$(basename "$scans")
  register_into "$bin" "$template" "$scans" "$out/true_$name" "${texture[@]}"
  [ -n "$calibration" ] || continue
  if [ ! -d "$out/scans_nolm_$name" ]; then  # the same scans without landmarks.json (hard links, nothing copied)
    mkdir -p "$out/scans_nolm_$name.tmp"
    for s in "$scans"/subject_*; do cp -al "$s" "$out/scans_nolm_$name.tmp/"; rm -f "$out/scans_nolm_$name.tmp/$(basename "$s")/landmarks.json"; done
    mv "$out/scans_nolm_$name.tmp" "$out/scans_nolm_$name"
  fi
  register_into "$bin" "$template" "$out/scans_nolm_$name" "$out/detected_$name" --landmark-calibration "$calibration" \
      "${texture[@]}"
done
register_table "$out" <<'PY'
import sys
from register_table import table

def row(kind, path, r):
    t = r.get("texture_refine", {})
    if "correspondence_error_before_mm" not in t:
        return None
    b, a, s = t["correspondence_error_before_mm"], r["correspondence_error_mm"], r["seconds"]
    return (b["median"], a["median"], b["p95"], a["p95"], s["total"] - s.get("texture_refine", 0),
            s.get("texture_refine", 0))

table(sys.argv[1], "", [[("median before", 13, 3, 0), ("after", 6, 3, 1), ("ratio", 5, 2, lambda v: v[1] / v[0])],
                        [("p95 before", 10, 3, 2), ("after", 6, 3, 3), ("ratio", 5, 2, lambda v: v[3] / v[2])],
                        [("s/scan", 6, 1, 4), ("+texture", 8, 1, 5)]], row, 22)
PY
