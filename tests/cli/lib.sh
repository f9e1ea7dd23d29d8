# The shared prologue of the command-line tests. A test starts with
#   source "$(dirname "$0")/lib.sh" "$@"
# (its first argument is the bareskin binary) and gets:
#   bin   the binary;  here  tests/cli;  py  the system python3 (numpy, skimage);  work  a temporary folder, removed on
#   exit;  fail MESSAGE (prints FAIL: MESSAGE, exits 1);  error_ok / expect_failure (below).
set -u
bin=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")  # absolute: some tests run from another folder
here=$(cd "$(dirname "${BASH_SOURCE[1]}")" && pwd)
lib_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)  # tests/cli, also when a bench script sources this
py=/usr/bin/python3
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*"; exit 1; }

# error_ok CODE NEEDLE OUTPUT -- command...: runs the command; true when it exits with CODE, prints exactly one line on
# stderr, that line holds NEEDLE (a fixed string), and OUTPUT (when not empty) was not left behind. The stderr stays
# in $work/err, the exit code in $error_code.
error_ok() {
  local code=$1 needle=$2 output=$3
  shift 4
  "$@" > /dev/null 2> "$work/err"
  error_code=$?
  [ "$error_code" -eq "$code" ] && [ "$(grep -c . "$work/err")" -eq 1 ] && grep -qF -- "$needle" "$work/err" \
    && { [ -z "$output" ] || [ ! -e "$output" ]; }
}

# expect_failure CODE NEEDLE OUTPUT -- command...: error_ok, or fail naming the command, its exit code and stderr.
expect_failure() {
  error_ok "$@" || fail "$* -> exit $error_code: $(cat "$work/err")"
}

# register_truth TEMPLATE_DIR SCANS_DIR OUT_DIR [MAPS...]: a registered folder without running `scan register`: per
# synthetic scan, the template's OBJ with its vertices moved to the scan's true dense correspondence
# (truth/correspondence.safetensors) as OUT_DIR/<id>/mesh.obj, and the named truth maps (default diffuse.png) copied.
register_truth() {
  local t=$1 scans=$2 out=$3
  shift 3
  "$py" "$lib_dir/../python/truth_registered.py" "$t/face.obj" "$scans" "$out" "$@" || fail "registered from the truth"
}

# tiny_face_world [SEED]: the smallest world `texgen faces` draws from, in $work: a 3000-vertex template (t/), three
# synthetic scans (s/, `scan synth --seed SEED`, default 1) registered from their truth with their diffuse, roughness
# and specular maps (r/), and a model built from them ($model = m/model.safetensors).
tiny_face_world() {
  "$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
  "$bin" scan synth -q --template "$work/t" --count 3 --seed "${1:-1}" --vertices 6000 --res 64 --truth-res 64 \
    -o "$work/s" || fail "synth"
  register_truth "$work/t" "$work/s" "$work/r" diffuse.png roughness.png specular.png
  model="$work/m/model.safetensors"
  "$bin" mm-build -q --template "$work/t" --appearance-res 32 --registered "$work/r" -o "$model" || fail "mm-build"
}

# tiny_faces DIR [SHARDS]: face samples in texgen faces' layout (32², 8 in DIR/train split over SHARDS shards, default
# 1, and 4 in DIR/test), written by an independent PNG and tar writer: the smallest data `train bareskin` takes.
tiny_faces() {
  "$py" - "$1" "$lib_dir/../python" "${2:-1}" <<'PY' || fail "could not write the test shards"
import io, json, os, sys, tarfile, zlib
import numpy as np
root, shards = sys.argv[1], int(sys.argv[3])
sys.path.insert(0, sys.argv[2])
from spec_writers import png
rng = np.random.default_rng(1)
yy, xx = np.mgrid[0:32, 0:32] / 31.0 * 2 - 1
disc = (xx**2 + yy**2 < 0.6).astype(float)
for split, count, parts in (("train", 8, shards), ("test", 4, 1)):
    os.makedirs(f"{root}/{split}", exist_ok=True)
    listed = []
    for part in range(parts):
        name = f"faces-{part:06d}.tar"
        samples = range(part * count // parts, (part + 1) * count // parts)
        with tarfile.open(f"{root}/{split}/{name}", "w") as tar:
            for i in samples:
                bare = 0.3 + 0.4 * rng.random(3)[None, None, :] * np.ones((32, 32, 1))
                before = bare * (0.8 + 0.2 * xx[..., None])
                makeup = before * 0.7 + 0.3 * np.array([0.8, 0.2, 0.3]) * disc[..., None]
                meta = {"subject": f"mm/{i}", "split": split, "style": "natural", "has_truth": True,
                        "landmarks": (rng.random((68, 2)) * 32).tolist()}
                for member, data in (("makeup.png", png(makeup)), ("before.png", png(before)), ("bare.png", png(bare)),
                                     ("skin.png", png(disc)), ("face.png", png(disc)),
                                     ("json", json.dumps(meta).encode())):
                    info = tarfile.TarInfo(f"{i:08d}.{member}")
                    info.size = len(data)
                    tar.addfile(info, io.BytesIO(data))
        data = open(f"{root}/{split}/{name}", "rb").read()
        listed.append({"name": name, "samples": len(samples), "crc32": zlib.crc32(data), "bytes": len(data)})
    json.dump({"format": "bareskin-shards/1", "samples": count, "metadata": {}, "shards": listed},
              open(f"{root}/{split}/manifest.json", "w"))
PY
}

# tiny_train OUT [FLAGS...]: `train bareskin`, stage 1 only, with the smallest nets on tiny_faces' $faces (default
# $work/faces), $tiny_steps steps (default 16), a checkpoint every 2 steps, one thread (so that every run of it gives
# the same bytes). Extra flags go last. tiny_command sets the array train_command to it, for `"${train_command[@]}" &`
# (a background function would be a subshell, and signals would reach the shell, not bareskin).
tiny_command() {
  local out=$1
  shift
  train_command=("$bin" train bareskin --data "${faces:-$work/faces}" --steps1 "${tiny_steps:-16}" --steps2 0 -o "$out"
    --size 32 --batch 4 --g-options '{"ngf": 8}' --d-options '{"ndf": 8, "n_layers": 2}' --ablation b --log-every 1
    --checkpoint-every 2 --eval-every 0 --sample-every 0 --threads 1 -q "$@")
}
tiny_train() {
  tiny_command "$@"
  "${train_command[@]}"
}

# checkpoint_step FILE: the step a training checkpoint holds (its safetensors metadata), read by the oracle reader.
checkpoint_step() {
  "$py" - "$lib_dir/../python" "$1" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[1])
from safetensors_oracle import read_safetensors
print(json.loads(read_safetensors(sys.argv[2])[0]["bareskin.checkpoint"])["step"])
PY
}

# wait_for FILE PID: until FILE exists (true) or process PID ended first or 120 s passed (false).
wait_for() {
  local i
  for ((i = 0; i < 2400; ++i)); do
    [ -e "$1" ] && return 0
    kill -0 "$2" 2> /dev/null || { [ -e "$1" ]; return; }
    sleep 0.05
  done
  return 1
}

# kill_and_resume OUT SECONDS: tiny_train into OUT, killed with SIGKILL after SECONDS, then run with --resume until
# it ends (a stage-1 run resumes from its checkpoint, or starts afresh where the kill left none). Prints the step of
# the checkpoint the kill left ("-": none; "end": the run had ended).
kill_and_resume() {
  local out=$1 pid status left=- checkpoint=$1/stage1/checkpoint.safetensors
  tiny_command "$out"
  "${train_command[@]}" 2> "$work/killed.err" &
  pid=$!
  sleep "$2"
  kill -9 "$pid" 2> /dev/null
  wait "$pid"
  status=$?
  if [ "$status" -eq 0 ]; then
    left=end
  elif [ "$status" -ne 137 ]; then
    fail "the run failed before it was killed (exit $status): $(cat "$work/killed.err")"
  elif [ -f "$checkpoint" ]; then
    left=$(checkpoint_step "$checkpoint") || fail "the kill left a checkpoint that does not read: $checkpoint"
  fi
  tiny_train "$out" --resume 2> "$work/resumed.err" || fail "resume after kill -9 at $2 s: $(cat "$work/resumed.err")"
  echo "$left"
}
