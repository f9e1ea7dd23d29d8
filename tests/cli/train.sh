#!/usr/bin/env bash
# bareskin train: the zoo listing (the issue's reference parameter counts), one model's options, export, and bad input.
source "$(dirname "$0")/lib.sh" "$@"

"$bin" train --list-models > "$work/list" || fail "train --list-models failed"
while read -r name count; do
  grep -qE "^$name +$count " "$work/list" || fail "$name should have $count parameters: $(grep "^$name " "$work/list")"
done <<'COUNTS'
resnet18 11,689,512
resnet50 25,557,032
unet256 54,413,955
patchgan 2,768,705
pix2pixhd_global 182,443,267
msrresnet 1,517,571
COUNTS

"$bin" train --print-model unet256 --options '{"ngf": 8, "num_downs": 6}' > "$work/unet" || fail "print-model failed"
grep -q '"ngf": 8' "$work/unet" || fail "print-model does not echo the options: $(cat "$work/unet")"
grep -q '"num_downs": 6' "$work/unet" || fail "print-model does not echo num_downs"
# U-Net ngf 8, 6 levels, 3->3 (pix2pix's layout): counted from its layers by tests/python/torchvision_oracle.py too.
count=$(grep -oP '^parameters: \K[0-9,]+' "$work/unet")
[ -n "$count" ] || fail "no parameter count printed"

expect_failure 3 "not in the zoo" "" -- "$bin" train --print-model unet512
expect_failure 3 "--options" "" -- "$bin" train --print-model unet256 --options '{"ngf": '
expect_failure 3 "ngff" "" -- "$bin" train --print-model unet256 --options '{"ngff": 8}'
expect_failure 2 "--list-models" "" -- "$bin" train
expect_failure 4 "nothing.safetensors" "$work/G.safetensors" -- "$bin" train export "$work/nothing.safetensors" --module G -o "$work/G.safetensors"
# train export: a BareSkinNet run folder (stage1/, stage2/) exports its last stage; damaged checkpoint metadata is
# refused in one line. The checkpoints come from tests/python/spec_writers.py (numpy, no code of ours).
$py - "$here/../python" "$work/bsn" <<'PY' || fail "writing the checkpoints"
import json, os, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from spec_writers import safetensors
def write(path, tensors, meta):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    safetensors(path, {name: ("F32", a.astype("<f4")) for name, a in tensors.items()}, meta)
run = sys.argv[2]
for stage, value in (("stage1", 1.0), ("stage2", 2.0)):
    meta = {"bareskin.checkpoint": json.dumps({"step": 3, "task": "bareskinnet", "config": {}})}
    write(f"{run}/{stage}/checkpoint.safetensors", {"module.G.w": np.full((2, 3), value)}, meta)
write(f"{run}/../damaged.safetensors", {"module.G.w": np.zeros(2)}, {"bareskin.checkpoint": '{"step": 3, "ta'})
PY
"$bin" train export "$work/bsn" --module G -o "$work/G_last.safetensors" -q || fail "export of a BareSkinNet run folder"
$py - "$here/../python" "$work/G_last.safetensors" <<'PY' || fail "export of a BareSkinNet run folder took another stage"
import sys
sys.path.insert(0, sys.argv[1])
from safetensors_oracle import read_safetensors
meta, tensors = read_safetensors(sys.argv[2])
assert (tensors["w"] == 2.0).all() and tensors["w"].shape == (2, 3), tensors
PY
expect_failure 3 "damaged.safetensors: has damaged checkpoint metadata" "$work/G.safetensors" -- "$bin" train export "$work/damaged.safetensors" --module G -o "$work/G.safetensors"
echo "train CLI: ok"
