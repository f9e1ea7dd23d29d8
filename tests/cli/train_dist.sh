#!/usr/bin/env bash
# Several ranks of one training (c10d Gloo on 127.0.0.1, two CPU processes as torchrun would start them) on a tiny
# stage-1 `train bareskin` run with two shards:
# - the two ranks train to the end together; only rank 0 writes the run folder;
# - one rank killed with -9 mid-run: the other stops within seconds, exit 4, one line saying a rank was lost;
# - one rank hung (SIGSTOP) with --dist-timeout 5: the other stops after the timeout (within 30 s), one line saying
#   how long it waited.
source "$(dirname "$0")/lib.sh" "$@"

tiny_faces "$work/faces" 2
port=$((20000 + $$ % 20000))

# rank R OUT [FLAGS...]: rank R of 2 of tiny_train into OUT, in the background; its pid in pids[R], its stderr in
# OUT.R.err.
declare -a pids
rank() {
  local r=$1 out=$2
  shift 2
  tiny_command "$out" "$@"
  RANK=$r WORLD_SIZE=2 LOCAL_RANK=0 MASTER_ADDR=127.0.0.1 MASTER_PORT=$port OMP_NUM_THREADS=1 \
    "${train_command[@]}" 2> "$out.$r.err" &
  pids[$r]=$!
}

# ---- two ranks to the end ----
mkdir -p "$work/runs"
rank 0 "$work/runs/both"
rank 1 "$work/runs/both"
for r in 0 1; do
  wait "${pids[$r]}" || fail "rank $r of a two-rank run failed: $(cat "$work/runs/both.$r.err")"
done
[ "$(checkpoint_step "$work/runs/both/stage1/checkpoint.safetensors")" = 16 ] || fail "the two-rank run did not end"
[ -f "$work/runs/both/eval.json" ] || fail "rank 0 did not evaluate the run"

# stops_alone OUT SIGNAL [FLAGS...]: both ranks started into OUT; once rank 0 wrote its first checkpoint, rank 1 gets
# SIGNAL; rank 0 must stop within 30 s. Its exit code in $status, its seconds in $took.
stops_alone() {
  local out=$1 signal=$2 start i
  shift 2
  port=$((port + 1))
  tiny_steps=100000 rank 0 "$out" "$@"
  tiny_steps=100000 rank 1 "$out" "$@"
  wait_for "$out/stage1/checkpoint.safetensors" "${pids[0]}" || fail "no first checkpoint: $(cat "$out.0.err")"
  kill "-$signal" "${pids[1]}"
  start=$SECONDS
  for ((i = 0; i < 300; ++i)); do
    kill -0 "${pids[0]}" 2> /dev/null || break
    sleep 0.1
  done
  took=$((SECONDS - start))
  kill -9 "${pids[0]}" "${pids[1]}" 2> /dev/null
  wait "${pids[0]}" 2> /dev/null
  status=$?
  wait "${pids[1]}" 2> /dev/null
  [ "$i" -lt 300 ] || fail "rank 0 still ran 30 s after rank 1 got SIG$signal"
}

stops_alone "$work/runs/killed" KILL
[ "$status" -eq 4 ] || fail "rank 0 after rank 1 died: exit $status, expected 4: $(cat "$work/runs/killed.0.err")"
[ "$(grep -c . "$work/runs/killed.0.err")" -eq 1 ] || fail "rank 0 after rank 1 died: not one line: $(cat "$work/runs/killed.0.err")"
grep -qF "rank 0 of 2: lost the connection to another rank" "$work/runs/killed.0.err" \
  || fail "rank 0 after rank 1 died: $(cat "$work/runs/killed.0.err")"

echo "rank 1 killed: rank 0 stopped after $took s: $(cat "$work/runs/killed.0.err")"
stops_alone "$work/runs/hung" STOP --dist-timeout 5
[ "$status" -eq 4 ] || fail "rank 0 beside a hung rank: exit $status, expected 4: $(cat "$work/runs/hung.0.err")"
[ "$(grep -c . "$work/runs/hung.0.err")" -eq 1 ] || fail "rank 0 beside a hung rank: not one line: $(cat "$work/runs/hung.0.err")"
grep -qF "rank 0 of 2: waited more than 5 s for the other ranks" "$work/runs/hung.0.err" \
  || fail "rank 0 beside a hung rank: $(cat "$work/runs/hung.0.err")"
[ "$took" -ge 4 ] || fail "rank 0 stopped after $took s, before the 5 s timeout: $(cat "$work/runs/hung.0.err")"
echo "rank 1 hung: rank 0 stopped after $took s: $(cat "$work/runs/hung.0.err")"
expect_failure 2 "--dist-timeout" "$work/runs/zero" -- env RANK=0 WORLD_SIZE=2 "$bin" train bareskin --data "$work/faces" \
  -o "$work/runs/zero" --dist-timeout 0
echo "distributed training under faults: ok"
