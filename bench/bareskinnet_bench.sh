#!/usr/bin/env bash
# BareSkinNet's G on the CPU: milliseconds per 256² photo (batch 1, forward only, median of 5 after a warm-up) for
# ngf 16 / 32 / 64 (64 = the paper's size), against the issue's goal of ≤ 300 ms at the paper's size. Each width is a
# one-step stage-1 run (its weights do not matter for the time) evaluated on a few test faces, which also times G.
#   bash bench/bareskinnet_bench.sh build/bin/bareskin FACES_DIR [--threads 2]
set -euo pipefail
bin=$1
faces=$2
shift 2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf '%-6s %-6s %12s %14s %10s\n' size ngf "params (M)" "G ms (ours)" "goal ms"
for ngf in 16 32 64; do
  "$bin" -q train bareskin --data "$faces" --steps1 1 --steps2 0 --ablation b --size 256 --batch 1 \
    --g-options "{\"ngf\": $ngf}" --eval-samples 2 --sample-every 0 --eval-every 0 -o "$work/g$ngf" "$@"
  params=$("$bin" train --print-model unet256 --options "{\"ngf\": $ngf}" | sed -n 's/^parameters: //p' | tr -d ,)
  /usr/bin/python3 - "$work/g$ngf/eval.json" "$ngf" "$params" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
print(f"{256:<6} {sys.argv[2]:<6} {int(sys.argv[3]) / 1e6:12.1f} {j['ms_per_image']:14.1f} {300 if sys.argv[2] == '64' else '':>10}")
PY
done
