#!/usr/bin/env bash
# scan register --texture-refine N against the synthetic truth: the correspondence error of each scan before the
# texture refinement (the NICP result, report.json's texture_refine.correspondence_error_before_mm) and after it, side
# by side with the ratio, from the scans' true landmarks and from detected (calibrated multi-view) landmarks.
# Usage: bench/register_texture.sh BIN TEMPLATE REFERENCE.png OUT CALIBRATION.json ROUNDS SCANS_DIR...
#   REFERENCE.png: the template-UV reference (bench/register_texture_reference.py over OTHER scans' registered
#   diffuse.png); CALIBRATION.json: `landmarks calibrate` on other scans ("" skips the detected-landmark rows).
# Extra `scan register` flags can be given in REGISTER_FLAGS. Rows are cached in OUT (delete it to rerun).
set -euo pipefail
bin=$1 template=$2 reference=$3 out=$4 calibration=$5 rounds=$6
shift 6
mkdir -p "$out"
for scans in "$@"; do
  name=$(basename "$scans")
  nice "$bin/bareskin" scan register -q --template "$template" --scans "$scans" -o "$out/true_$name" --maps-res 0 \
      --texture-refine "$rounds" --texture-reference "$reference" ${REGISTER_FLAGS:-}
  [ -n "$calibration" ] || continue
  if [ ! -d "$out/scans_nolm_$name" ]; then  # the same scans without landmarks.json (hard links, nothing copied)
    mkdir -p "$out/scans_nolm_$name.tmp"
    for s in "$scans"/subject_*; do cp -al "$s" "$out/scans_nolm_$name.tmp/"; rm -f "$out/scans_nolm_$name.tmp/$(basename "$s")/landmarks.json"; done
    mv "$out/scans_nolm_$name.tmp" "$out/scans_nolm_$name"
  fi
  nice "$bin/bareskin" scan register -q --template "$template" --scans "$out/scans_nolm_$name" -o "$out/detected_$name" \
      --maps-res 0 --landmark-calibration "$calibration" --texture-refine "$rounds" --texture-reference "$reference" \
      ${REGISTER_FLAGS:-}
done
/usr/bin/python3 - "$out" <<'PY'
import glob, json, os, statistics as st, sys
out = sys.argv[1]
print(f"{'landmarks':<9} {'scan':<22} | {'median before':>13} {'after':>6} {'ratio':>5} | {'p95 before':>10} {'after':>6} "
      f"{'ratio':>5} | {'s/scan':>6} {'+texture':>8}")
for kind in ("true", "detected"):
    rows = []
    for path in sorted(glob.glob(f"{out}/{kind}_*/subject_*/report.json")):
        r = json.load(open(path))
        t = r.get("texture_refine", {})
        if "correspondence_error_before_mm" not in t:
            continue
        b, a = t["correspondence_error_before_mm"], r["correspondence_error_mm"]
        s = r["seconds"]
        rows.append((b["median"], a["median"], b["p95"], a["p95"], s["total"] - s.get("texture_refine", 0), s.get("texture_refine", 0)))
        scan = path.split("/")[-3].split("_", 1)[1] + "/" + path.split("/")[-2]
        print(f"{kind:<9} {scan:<22} | {b['median']:13.3f} {a['median']:6.3f} {a['median'] / b['median']:5.2f} | "
              f"{b['p95']:10.3f} {a['p95']:6.3f} {a['p95'] / b['p95']:5.2f} | {rows[-1][4]:6.1f} {rows[-1][5]:8.1f}")
    if rows:
        m = [st.median(c) for c in zip(*rows)]
        print(f"{kind:<9} {'MEDIAN of ' + str(len(rows)) + ' scans':<22} | {m[0]:13.3f} {m[1]:6.3f} {m[1] / m[0]:5.2f} | "
              f"{m[2]:10.3f} {m[3]:6.3f} {m[3] / m[2]:5.2f} | {m[4]:6.1f} {m[5]:8.1f}")
PY
