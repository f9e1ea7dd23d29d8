#!/usr/bin/env bash
# The paper's Fig. 7 ablation at the CPU profile (`train bareskin --profile cpu --ablation b..g`), several seeds per row,
# all on the same face shards and teacher F, each run scored by its own held-out evaluation (<run>/eval.json: the
# test split, subjects and makeup styles never trained on). Rows (b) and (c) are stage 1 alone; (d)-(g) add stage 2,
# which each row starts from a copy of the same seed's (c) stage 1 (stage 1 is the same training in rows c-g, so the
# rows of one seed differ only in what the paper's step changes). Usage:
#   bash bench/bareskinnet_ablation.sh <bin> <faces/> <teacher F run> <model.safetensors> <out/> [size=64] \
#     [steps1=600] [steps2=200] [seeds=0,1,2]
# Prints a Markdown table: per row the mean over seeds of the PSNR on skin against the bare truth, of F's unlit albedo
# of G's output (what stage 2 is for) and of the PSNR against the before-makeup photo, with 95% intervals over seeds
# (Student's t), and each row's step from the row above as the mean of the paired per-seed differences with its
# interval: a step holds outside seed noise when its interval excludes 0. Finished runs are skipped, so a killed
# bench resumes.
set -euo pipefail
bin=$1 faces=$2 teacher=$3 model=$4 out=$5
size=${6:-64} steps1=${7:-600} steps2=${8:-200} seeds=${9:-0,1,2}
mkdir -p "$out"
for seed in ${seeds//,/ }; do
  for row in b c d e f g; do
    run="$out/${row}_seed$seed"
    [ -f "$run/eval.json" ] && continue
    if [ "$row" != b ] && [ "$row" != c ] && [ ! -d "$run/stage1" ]; then
      mkdir -p "$run" && cp -r "$out/c_seed$seed/stage1" "$run/stage1"
    fi
    echo "ablation ($row), seed $seed: ${size}², $steps1 + $steps2 steps" >&2
    nice "$bin/bareskin" -q --threads 2 train bareskin --profile cpu --data "$faces" -o "$run" --resume --size "$size" \
      --ablation "$row" --steps1 "$steps1" --steps2 "$steps2" --teacher "$teacher" --model "$model" --seed "$seed" \
      --log-every 50 --checkpoint-every 100 --eval-every 0 --sample-every 0
  done
done
/usr/bin/python3 - "$out" "$seeds" "$(dirname "$0")" <<'PY'
import json, os, sys
out, seeds = sys.argv[1], sys.argv[2].split(",")
sys.path.insert(0, sys.argv[3])
from table1_intervals import interval  # mean over groups ± Student's t
names = {"b": "L1 + GAN", "c": "+ LPIPS", "d": "+ frozen F (stage 2)", "e": "+ fine-tuned F", "f": "+ E, no L_light",
         "g": "full"}
keys = [("psnr_bare", "PSNR vs bare"), ("psnr_albedo_bare", "F's unlit albedo vs bare"),
        ("psnr_before", "PSNR vs before")]
of_input = {"psnr_bare": "psnr_input_bare", "psnr_albedo_bare": "psnr_albedo_input_bare",
            "psnr_before": "psnr_input_before"}
m = {(r, s): json.load(open(os.path.join(out, f"{r}_seed{s}", "eval.json")))["mean"] for r in names for s in seeds}
def ci(values):  # one value per seed: the seeds are the groups
    mean, half, _ = interval({s: [v] for s, v in zip(seeds, values)})
    return mean, half
print(f"| row | losses | " + " | ".join(f"{t} (dB)" for _, t in keys) + " | step from the row above: " + keys[0][1] +
      " / " + keys[1][1] + " |")
print("|---|---|" + "---|" * len(keys) + "---|")
base = [m[("b", s)] for s in seeds]
print("| — | the input unchanged | " + " | ".join("%.2f ± %.2f" % ci([b[of_input[k]] for b in base]) for k, _ in keys) +
      " | — |")
rows = list(names)
for i, r in enumerate(rows):
    cells = ["%.2f ± %.2f" % ci([m[(r, s)][k] for s in seeds]) for k, _ in keys]
    step = "—"
    if i > 0:
        parts = []
        for k in (keys[0][0], keys[1][0]):
            d, h = ci([m[(r, s)][k] - m[(rows[i - 1], s)][k] for s in seeds])
            parts.append(("%+.2f ± %.2f" % (d, h)) + (" **holds**" if abs(d) > h else ""))
        step = " / ".join(parts)
    print(f"| ({r}) | {names[r]} | " + " | ".join(cells) + f" | {step} |")
print(f"\n{len(seeds)} seeds ({', '.join(seeds)}); ± is the 95% interval over seeds (Student's t); a step holds when the "
      "interval of its paired per-seed differences excludes 0.")
PY
