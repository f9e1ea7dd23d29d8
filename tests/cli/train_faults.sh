#!/usr/bin/env bash
# Training under faults (docs/reliability.md, "Training under faults"), on a tiny stage-1 `train bareskin` run:
# - a shard damaged while the run reads it stops the run with one line naming the shard and the member; the last
#   checkpoint stays readable; --resume after the repair ends with the same bytes as an uninterrupted run;
# - a write that fails while a checkpoint is written (the file size limit lowered under the running process with
#   prlimit: EFBIG, as ENOSPC on a full disk) stops the run with one line; the previous checkpoint keeps its bytes, no
#   temporary is left; --resume ends with the same bytes;
# - kill -9 at two random moments, then --resume: the same bytes (bench/kill_resume_soak.sh, which does ten in the
#   bench).
source "$(dirname "$0")/lib.sh" "$@"

tiny_faces "$work/faces"
shard=$work/faces/train/faces-000000.tar
tiny_train "$work/ref" 2> "$work/ref.err" || fail "the uninterrupted run failed: $(cat "$work/ref.err")"
ref=$work/ref/stage1/checkpoint.safetensors
[ "$(checkpoint_step "$ref")" = "${tiny_steps:-16}" ] || fail "the uninterrupted run did not end at its last step"

# started_and_stopped OUT: tiny_train into OUT in the background ($pid), stopped (SIGSTOP) once its first checkpoint
# is there.
started_and_stopped() {
  tiny_command "$1"
  "${train_command[@]}" 2> "$1.err" &
  pid=$!
  wait_for "$1/stage1/checkpoint.safetensors" "$pid" || fail "no checkpoint was written: $(cat "$1.err")"
  kill -STOP "$pid"
}

# same_as_ref OUT WHAT: OUT's final checkpoint has the uninterrupted run's bytes.
same_as_ref() {
  cmp -s "$1/stage1/checkpoint.safetensors" "$ref" || fail "$2: the resumed run's checkpoint differs from the uninterrupted run's"
}

# ---- a shard damaged mid-run ----
started_and_stopped "$work/a"
cp "$shard" "$work/shard.good"
"$py" - "$shard" <<'PY' || fail "could not damage the shard"
import sys, tarfile
with tarfile.open(sys.argv[1]) as tar:
    offset = tar.getmember("00000005.makeup.png").offset_data
with open(sys.argv[1], "r+b") as f:  # the PNG's image data, past its 8-byte signature and IHDR chunk
    f.seek(offset + 41)
    f.write(b"\xff" * 24)
PY
kill -CONT "$pid"
wait "$pid"
status=$?
[ "$status" -eq 3 ] || fail "a damaged shard: exit $status, expected 3: $(cat "$work/a.err")"
[ "$(grep -c . "$work/a.err")" -eq 1 ] || fail "a damaged shard: not one line: $(cat "$work/a.err")"
for needle in faces-000000.tar 00000005.makeup.png "training stopped and the last good checkpoint is" --resume; do
  grep -qF -- "$needle" "$work/a.err" || fail "a damaged shard: the message lacks '$needle': $(cat "$work/a.err")"
done
named=$(grep -oP 'checkpoint.safetensors \(step \K[0-9]+' "$work/a.err")
[ "$(checkpoint_step "$work/a/stage1/checkpoint.safetensors")" = "$named" ] \
  || fail "the checkpoint left is not the one the message names (step $named)"
cp "$work/shard.good" "$shard"
tiny_train "$work/a" --resume 2> "$work/a.err" || fail "resume after the repair: $(cat "$work/a.err")"
same_as_ref "$work/a" "a damaged shard"

# ---- a failed checkpoint write (the disk full) ----
started_and_stopped "$work/b"
cp "$work/b/stage1/checkpoint.safetensors" "$work/b.before"
size=$(stat -c %s "$work/b.before")
prlimit --pid "$pid" --fsize=$((size / 2)) || fail "prlimit could not lower the file size limit"
kill -CONT "$pid"
wait "$pid"
status=$?
[ "$status" -eq 4 ] || fail "a failed checkpoint write: exit $status, expected 4: $(cat "$work/b.err")"
[ "$(grep -c . "$work/b.err")" -eq 1 ] || fail "a failed checkpoint write: not one line: $(cat "$work/b.err")"
for needle in "stage1/checkpoint.safetensors: write failed (File too large)" "the last good checkpoint is" --resume; do
  grep -qF -- "$needle" "$work/b.err" || fail "a failed checkpoint write: the message lacks '$needle': $(cat "$work/b.err")"
done
# The checkpoint left is the one the message names. The stop can land after the next checkpoint's temporary was
# written in full but before its rename: that checkpoint then lands whole, and the write after it is the one that
# fails. Either way the named checkpoint is complete, and when it is the one from before the limit it kept its bytes.
named=$(grep -oP 'checkpoint.safetensors \(step \K[0-9]+' "$work/b.err")
[ "$(checkpoint_step "$work/b/stage1/checkpoint.safetensors")" = "$named" ] \
  || fail "a failed checkpoint write: the checkpoint left is not the one the message names (step $named)"
if [ "$named" = "$(checkpoint_step "$work/b.before")" ]; then
  cmp -s "$work/b/stage1/checkpoint.safetensors" "$work/b.before" || fail "the failed write changed the previous checkpoint"
fi
left=$(ls -A "$work/b/stage1" | grep -c '^\.checkpoint')
[ "$left" -eq 0 ] || fail "the failed write left a temporary: $(ls -A "$work/b/stage1")"
tiny_train "$work/b" --resume 2> "$work/b.err" || fail "resume after the failed write: $(cat "$work/b.err")"
same_as_ref "$work/b" "a failed checkpoint write"

# ---- kill -9 at two random moments of the uninterrupted run's length ----
bash "$here/../../bench/kill_resume_soak.sh" "$bin" 2 > "$work/soak.out" || fail "kill -9 soak: $(cat "$work/soak.out")"
echo "training under faults: ok"
