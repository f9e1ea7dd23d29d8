#!/usr/bin/env bash
# The kill -9 soak of training: one small training (tests/cli/lib.sh's tiny_train: `train bareskin` stage 1, tiny
# nets on 8 faces of 32², 120 steps, a checkpoint every 2) is run twice straight through, then MOMENTS times started
# afresh, killed with SIGKILL at a moment drawn uniformly over the straight run's length, and resumed with --resume
# until it ends. Every resumed run must end with the straight run's checkpoint, byte for byte. Prints one row per
# moment (the kill's second, the checkpoint step the kill left, the verdict) and exits 1 on any difference.
# CI (tests/cli/train_faults.sh) runs two moments; BENCHMARKS "Reliability" records a run of ten.
#   bash bench/kill_resume_soak.sh <bareskin binary> [MOMENTS=10] [SEED]
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/tests/cli/lib.sh" "$1"
moments=${2:-10}
seed=${3:-$RANDOM}
# 120 steps (about 4 s of training on 2 busy cores after 2 s of start-up, then the held-out evaluation) so that most
# moments fall inside the training.
tiny_steps=120
tiny_faces "$work/faces"
# Two straight runs: the first warms the caches (a cold start takes twice as long, and moments drawn over it would
# mostly fall after the end), the second gives the length; both must end with the same bytes.
tiny_train "$work/warm" 2> "$work/ref.err" || fail "the straight run failed: $(cat "$work/ref.err")"
start=$(date +%s.%N)
tiny_train "$work/ref" 2> "$work/ref.err" || fail "the straight run failed: $(cat "$work/ref.err")"
length=$("$py" -c "import sys, time; print(round(time.time() - float(sys.argv[1]), 2))" "$start")
cmp -s "$work/warm/stage1/checkpoint.safetensors" "$work/ref/stage1/checkpoint.safetensors" \
  || fail "two straight runs ended with different bytes"
read -r -a delays <<< "$("$py" -c "import random, sys; r = random.Random(int(sys.argv[1]))
print(' '.join(str(round(r.uniform(0, float(sys.argv[2])), 2)) for _ in range(int(sys.argv[3]))))" "$seed" "$length" "$moments")"
echo "kill -9 soak: straight run ${length} s ($tiny_steps steps), $moments moments drawn with seed $seed"
printf '%-8s %-10s %-22s %s\n' moment "kill at s" "checkpoint left (step)" "final checkpoint"  # -: none yet
different=0
for ((m = 0; m < moments; ++m)); do
  left=$(kill_and_resume "$work/run$m" "${delays[$m]}") || { echo "$left"; exit 1; }
  verdict=identical
  cmp -s "$work/run$m/stage1/checkpoint.safetensors" "$work/ref/stage1/checkpoint.safetensors" || { verdict=DIFFERS; different=1; }
  printf '%-8s %-10s %-22s %s\n' "$((m + 1))" "${delays[$m]}" "$left" "$verdict"
  rm -rf "$work/run$m"
done
[ "$different" -eq 0 ] || fail "a resumed run ended with other bytes than the straight run"
echo "kill -9 soak: $moments of $moments resumed runs identical to the straight run"
