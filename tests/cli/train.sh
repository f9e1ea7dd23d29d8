#!/usr/bin/env bash
# bareskin train: the zoo listing (the issue's reference parameter counts), one model's options, and bad input.
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
echo "train CLI: ok"
