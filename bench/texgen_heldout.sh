#!/usr/bin/env bash
# Held-out quality of `texgen make-dataset`'s merged unwrap (bench/BENCHMARKS.md, make-dataset section): the demo's
# registered subjects in two halves, A (the first 40 %: subjects 0–3 of 10) and B (the rest). Each half is fitted
# with a `landmarks calibrate` file made on the other half's scans, and with VIEWCAL=1 also with a per-view
# calibration (--view-calibration) learned on the other half's renders; nothing of a subject's own truth reaches its
# fit. Runs at the paper's 1K (renders, inputs, targets), no high-res targets, no masks.
#   bash bench/texgen_heldout.sh <bin> <demo> <out> NAME [make-dataset flags...]
# <demo>: a demo output (registered/, scans/, model/model.safetensors). Writes <out>/NAME/{a,b}/ and prints per subject
# the merged unwrap's PSNR vs the truth diffuse, the fitted shape's error (mm) and the CPU seconds, then the means.
# The calibrations are made once under <out>/ and reused.
set -euo pipefail
bin=$1 demo=$2 out=$3 name=$4
shift 4
mkdir -p "$out"
out=$(cd "$out" && pwd)
mapfile -t subjects < <(find "$demo/scans" -mindepth 1 -maxdepth 1 -type d -name 'subject_*' -printf '%f\n' | sort)
n=${#subjects[@]}
na=$(( (2 * n + 4) / 5 ))  # 40 %: 4 of 10
[ "$na" -ge 2 ] && [ $(( n - na )) -ge 2 ] || { echo "need 5 subjects at least, found $n" >&2; exit 1; }
common=(--model "$demo/model/model.safetensors" --render-size 1024 --split 1,0,0 --masks 0 --hr-res 0)
half_of() { [ "$1" -lt "$na" ] && echo a || echo b; }
for kind in scans registered; do  # the halves as folders of links
  [ -d "$out/${kind}_b" ] && continue
  mkdir -p "$out/${kind}_a" "$out/${kind}_b"
  for i in "${!subjects[@]}"; do
    ln -s "$(cd "$demo/$kind/${subjects[$i]}" && pwd)" "$out/${kind}_$(half_of "$i")/${subjects[$i]}"
  done
done
for half in a b; do  # the 3D convention calibration of each half (`landmarks calibrate` on its scans)
  [ -f "$out/cal_$half.json" ] && continue
  "$bin/bareskin" -q --threads 2 landmarks calibrate --scans "$out/scans_$half" -o "$out/cal_$half.tmp.json"
  mv "$out/cal_$half.tmp.json" "$out/cal_$half.json"
done
other() { [ "$1" = a ] && echo b || echo a; }
# The per-view calibration of half h: learned on half h's renders with the 3D calibration the other half is run with
# (the targets at 1024² as in the runs below: the renders' texture is the baked diffuse, and the detector's points
# move with it).
if [ "${VIEWCAL:-0}" = 1 ]; then
  for half in a b; do
    [ -f "$out/view_$half.json" ] && continue
    rm -rf "$out/learn_$half"
    "$bin/bareskin" -q --threads 2 texgen make-dataset "$out/registered_$half" "${common[@]}" --input-res 256 \
      --target-res 1024 --landmark-calibration "$out/cal_$half.json" -o "$out/learn_$half" \
      --write-view-calibration "$out/view_$half.json"
  done
fi
for half in a b; do
  o=$(other "$half")
  extra=()
  [ "${VIEWCAL:-0}" = 1 ] && extra=(--view-calibration "$out/view_$o.json")
  rm -rf "$out/$name/$half"
  mkdir -p "$out/$name"
  /usr/bin/time -f "%U %S %e" -o "$out/$name/$half.time" "$bin/bareskin" -q --threads 2 texgen make-dataset \
    "$out/registered_$half" "${common[@]}" --input-res 1024 --target-res 1024 --landmark-calibration "$out/cal_$o.json" \
    -o "$out/$name/$half" "${extra[@]}" "$@"
done
python3 - "$out/$name" <<'PY'
import glob, json, sys
root = sys.argv[1]
rows = []
for half in "ab":
    user, sys_s, wall = map(float, open(f"{root}/{half}.time").read().split()[-3:])
    reports = sorted(glob.glob(f"{root}/{half}/reports/*.json"))
    for p in reports:
        r = json.load(open(p))
        light = r["lights"][0]
        shape = sum(v["shape_error_mm"] for v in light["views"]) / len(light["views"])
        rows.append((half, r["subject"], light["unwrap"]["psnr_db_vs_truth"], shape, (user + sys_s) / len(reports)))
for half, s, psnr, mm, cpu in rows:
    print(f"{half} {s:>12} {psnr:6.2f} dB {mm:5.2f} mm {cpu:5.2f} CPU-s")
for half in "ab":
    h = [r for r in rows if r[0] == half]
    print(f"half {half}: {sum(r[2] for r in h) / len(h):.2f} dB, {sum(r[3] for r in h) / len(h):.2f} mm")
print(f"all {len(rows)}: {sum(r[2] for r in rows) / len(rows):.2f} dB, {sum(r[3] for r in rows) / len(rows):.2f} mm, "
      f"{sum(r[4] for r in rows) / len(rows):.2f} CPU-s per subject")
PY
