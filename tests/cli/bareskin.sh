#!/usr/bin/env bash
# bareskin train bareskin / bareskin demakeup: a tiny stage-1 run on face shards written here (Python: tar + PNG), its
# held-out evaluation, and bad input: a teacher checkpoint of another model, corrupt shards, a photo without a face.
source "$(dirname "$0")/lib.sh" "$@"

tiny_faces "$work/faces"

small=(--size 32 --batch 4 --g-options '{"ngf": 8}' --d-options '{"ndf": 8, "n_layers": 2}' --ablation b
       --log-every 1 --checkpoint-every 2 --eval-every 0 --sample-every 2 --eval-samples 4 --threads 2 -q)
"$bin" train bareskin --data "$work/faces" --steps1 2 -o "$work/bsn" "${small[@]}" \
  || fail "a stage-1 run failed: $("$bin" train bareskin --data "$work/faces" --steps1 2 -o "$work/bsn2" "${small[@]}" 2>&1 | tail -3)"
[ -f "$work/bsn/stage1/checkpoint.safetensors" ] || fail "no stage-1 checkpoint"
[ ! -e "$work/bsn/stage2" ] || fail "ablation row b trained a second stage"
"$py" - "$work/bsn/eval.json" <<'PY' || fail "eval.json: $(cat "$work/bsn/eval.json")"
import json, sys
j = json.load(open(sys.argv[1]))
assert j["samples"] == 4, j["samples"]
for k in ("psnr_bare", "ssim_bare", "psnr_before", "psnr_input_bare"):
    assert k in j["mean"] and j["mean"][k] == j["mean"][k], k  # present and not NaN
assert j["ms_per_image"] > 0
PY
# The do-nothing baseline where the makeup is (mean |makeup - before| > 0.02 on face.png), against the bare truth and
# the before image, recomputed here from the test shard's PNGs: the mean over the images of each one's PSNR.
"$py" - "$work/bsn/eval.json" "$work/faces/test" <<'PY' || fail "eval.json's makeup-region figures"
import glob, io, json, sys, tarfile
import numpy as np, skimage.io
m = json.load(open(sys.argv[1]))["mean"]
samples = {}
for shard in sorted(glob.glob(sys.argv[2] + "/*.tar")):
    with tarfile.open(shard) as tar:
        for member in tar.getmembers():
            key, part = member.name.split(".", 1)
            if part.endswith("png"):
                samples.setdefault(key, {})[part] = skimage.io.imread(io.BytesIO(tar.extractfile(member).read())) / 255.0
for truth in ("bare", "before"):
    psnr = []
    for s in samples.values():
        region = (np.abs(s["makeup.png"] - s["before.png"]).mean(-1) > 0.02) & (s["face.png"] >= 0.5)
        psnr.append(10 * np.log10(1 / ((s["makeup.png"] - s[truth + ".png"])[region] ** 2).mean()))
    ours = m["psnr_makeup_input_" + truth]
    print(f"makeup region, input vs {truth}: eval.json {ours:.4f} dB, numpy {np.mean(psnr):.4f} dB")
    assert abs(ours - np.mean(psnr)) < 0.01 and m["psnr_makeup_" + truth] == m["psnr_makeup_" + truth], truth
PY
# --loss-weights reaches the run's configuration (it once iterated a destroyed temporary and crashed); a key that is
# not a loss weight is refused.
"$bin" train bareskin --data "$work/faces" --steps1 1 -o "$work/bsnw" "${small[@]}" --loss-weights '{"w2": 0.5, "w_diff": 250}' \
  || fail "a run with --loss-weights failed"
"$py" -c "
import json, sys
t = json.load(open('$work/bsnw/stage1/config.json'))['task']
assert t['w2'] == 0.5 and t['w_diff'] == 250 and t['w1'] == 100, t" || fail "--loss-weights not in the configuration"
expect_failure 3 "not a loss weight" "$work/bsnw2" -- "$bin" train bareskin --data "$work/faces" --steps1 1 -o "$work/bsnw2" \
  "${small[@]}" --loss-weights '{"lr": 1}'
# An ablation row keeps out what it leaves out, whatever weights are given beside it (row b, as in small: no LPIPS).
"$bin" train bareskin --data "$work/faces" --steps1 1 -o "$work/bsnb" "${small[@]}" --loss-weights '{"w3": 40}' \
  || fail "an ablation run with --loss-weights failed"
"$py" -c "
import json
t = json.load(open('$work/bsnb/stage1/config.json'))['task']
assert t['w3'] == 0, t" || fail "--loss-weights undid the ablation row (row b with LPIPS)"
# A JSON object beside a profile that sets the same flag adds to the profile's keys instead of replacing them: the
# CPU profile's L_diff and L_light (20) and G's width (16) stay.
"$bin" train bareskin --profile cpu --size 32 --batch 2 --steps1 1 --steps2 0 --eval-samples 2 --data "$work/faces" \
  -o "$work/bsnp" --loss-weights '{"w3": 30}' --g-options '{"upsample": "resize_conv"}' --sample-every 0 \
  --eval-every 0 -q || fail "a profile run with --loss-weights and --g-options failed"
"$py" -c "
import json; c = json.load(open('$work/bsnp/stage1/config.json')); t = c['task']
assert t['w3'] == 30 and t['w_diff'] == 20 and t['w_light'] == 20, t
assert t['g']['ngf'] == 16 and t['g']['upsample'] == 'resize_conv', t['g']
assert c['profile']['overrides']['--loss-weights'] == '{\"w3\": 30}', c['profile']" \
  || fail "--loss-weights or --g-options beside a profile replaced the profile's keys instead of adding to them"

# An unknown profile: one line naming the profiles, nothing written (train recon's too).
expect_failure 3 "use one of paper, cpu" "$work/bsnw2" -- "$bin" train bareskin --profile gpu --data "$work/faces" \
  -o "$work/bsnw2"
expect_failure 3 "use one of paper, cpu" "$work/Fbad" -- "$bin" train recon --profile laptop --data "$work/faces" \
  --model "$work/none.safetensors" -o "$work/Fbad"
# A second run into the same folder without --resume is refused; --resume of a finished run trains nothing more.
expect_failure 3 "already holds a run" "" -- "$bin" train bareskin --data "$work/faces" --steps1 2 -o "$work/bsn" "${small[@]}"

# The teacher must be a recon run holding F: a BareSkinNet checkpoint is refused before anything is trained.
expect_failure 3 "not of the teacher F" "$work/bsn3" -- "$bin" train bareskin --data "$work/faces" --steps1 1 --steps2 1 \
  --teacher "$work/bsn/stage1" --model "$work/none.safetensors" -o "$work/bsn3" --size 32 -q
expect_failure 3 "--teacher" "$work/bsn3" -- "$bin" train bareskin --data "$work/faces" --steps1 1 --steps2 1 -o "$work/bsn3" -q
# Also a teacher given only for eval.json's albedo metrics (stage 1 alone).
expect_failure 3 "not of the teacher F" "$work/bsn3" -- "$bin" train bareskin --data "$work/faces" --steps1 1 --steps2 0 \
  --teacher "$work/bsn/stage1" -o "$work/bsn3" --size 32 -q
# Corrupt shards: one line, nothing written.
mkdir -p "$work/bad/train"
cp "$work/faces/train/manifest.json" "$work/bad/train/"
head -c 3000 "$work/faces/train/faces-000000.tar" > "$work/bad/train/faces-000000.tar"
expect_failure 3 "faces-000000.tar" "$work/bsn4" -- "$bin" train bareskin --data "$work/bad" --steps1 1 --steps2 0 -o "$work/bsn4" -q
expect_failure 3 "train/manifest.json" "$work/bsn4" -- "$bin" train bareskin --data "$work/nowhere" --steps1 1 -o "$work/bsn4" -q

# demakeup: a photo without a face (flat grey) fails before any output is made; a missing run names itself.
"$py" -c "
import numpy as np, skimage.io
skimage.io.imsave('$work/grey.png', np.full((160, 160, 3), 128, np.uint8), check_contrast=False)"
expect_failure 3 "no face was found" "$work/out" -- "$bin" demakeup "$work/grey.png" --run "$work/bsn" -o "$work/out" -q
# --aligned takes aligned 256² faces only: a 160² image is refused before the networks load.
expect_failure 3 "not an aligned 256" "$work/out" -- "$bin" demakeup "$work/grey.png" --aligned --run "$work/bsn" -o "$work/out" -q
expect_failure 4 "nothing" "$work/out" -- "$bin" demakeup "$work/nothing.png" --run "$work/bsn" -o "$work/out" -q
echo "bareskin CLI: ok"
