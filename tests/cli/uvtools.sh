#!/usr/bin/env bash
# uvtools bake through the command line: truth maps in the template UV (`scan synth --truth-res`) resized to two sizes,
# checked by the numpy + oiiotool oracle (tests/python/bake_oracle.py) in PNG and EXR (tiled half with mip levels);
# --toksvig raises roughness where normals vary; bad input (mixed sizes, non-square, a size that does not divide, a
# zero normal, a truncated EXR, a size that is not a number) gets one line, exit 3, and no output folder; `uvtools
# mean` against numpy, and a map of another size refused.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 1 --vertices 8000 --res 0 --truth-res 256 -o "$work/s" || fail "synth"
maps=$work/s/subject_0000/truth/maps
bake() { "$bin" uvtools bake -q --layout "$work/t/face.obj" "$@"; }

bake "$maps" -o "$work/png" --sizes 128,64 --format png || fail "bake png"
$py "$here/../python/bake_oracle.py" "$work/t/face.obj" "$maps" "$work/png" 128 64 || fail "oracle png"
bake "$maps" -o "$work/exr" --sizes 128,64 --format exr --mipmap || fail "bake exr"
oiiotool --info -v "$work/exr/128/diffuse.exr" | grep -q "MIP-map levels: 128x128 64x64" || fail "exr mip levels"
oiiotool --info "$work/exr/128/normal.exr" | grep -q "half" || fail "exr half"
$py "$here/../python/bake_oracle.py" "$work/t/face.obj" "$maps" "$work/exr" 128 64 || fail "oracle exr"
bake "$maps" -o "$work/tok" --sizes 64 --format exr --toksvig || fail "bake toksvig"
$py - "$here/../python" "$work/t/face.obj" "$maps" "$work/exr/64/roughness.exr" "$work/tok/64/roughness.exr" <<'PY' \
  || fail "toksvig"
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import island_mask, read
# r' = sqrt(sqrt(r^4 + (1 - L) / L)) with L the length of the island-averaged normal (GGX alpha = r^2).
n = 2 * read(sys.argv[3] + "/normal.png")[..., :3] - 1
N, s = n.shape[0], 64
mask = island_mask(sys.argv[2], N)
w = mask.reshape(s, N // s, s, N // s).sum((1, 3))
L = np.linalg.norm((n * mask[..., None]).reshape(s, N // s, s, N // s, 3).sum((1, 3)), axis=2) / np.maximum(w, 1)
r, got = read(sys.argv[4])[..., 0], read(sys.argv[5])[..., 0]
L = np.clip(L, 1e-3, 1)
want = np.sqrt(np.minimum(1, np.sqrt(r ** 4 + (1 - L) / L)))
err = np.abs(want - got)[w > 0].max()
assert err < 2e-3, f"Toksvig roughness off by {err}"
assert (got >= r - 1e-3)[w > 0].all(), "Toksvig lowered roughness"
print(f"ok   toksvig: max |ours - formula| {err:.1e}, roughness raised on {(got > r + 1e-4)[w > 0].mean():.1%} of texels")
PY

# unwarp: a render of the template with the truth diffuse, unwarped back, reproduces the map where seen.
"$bin" render -q "$work/t/face.obj" --texture "$maps/diffuse.png" --camera pinhole --passes albedo --size 512 \
  -o "$work/render.png" || fail "render"
"$bin" uvtools unwarp -q "$work/render.png" --mesh "$work/t/face.obj" --size 256 -o "$work/uv.png" || fail "unwarp"
$py - "$here/../python" "$work/uv.png" "$work/uv_confidence.png" "$maps/diffuse.png" <<'PY' || fail "unwarp round trip"
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import read
u, c, t = read(sys.argv[2])[..., :3], read(sys.argv[3])[..., 0], read(sys.argv[4])[..., :3]
seen = c > 0.5
psnr = 10 * np.log10(1 / ((u - t)[seen] ** 2).mean())
assert seen.mean() > 0.3 and psnr > 35, (seen.mean(), psnr)
print(f"ok   unwarp round trip: PSNR {psnr:.1f} dB over {seen.sum()} texels seen at confidence > 0.5")
PY
oiiotool "$work/render.png" --resize 512x256 -o "$work/wide.png"
expect_failure 3 "not square" "$work/bad_uv.png" -- \
  "$bin" uvtools unwarp -q "$work/wide.png" --mesh "$work/t/face.obj" -o "$work/bad_uv.png"

# mask: synthetic occluders cover part of the face; the written labels give the same mask back through the label path.
lm=$work/t/landmarks.json
"$bin" uvtools mask -q --mesh "$work/t/face.obj" --synthetic glasses,hand --landmarks "$lm" --seed 2 --image-size 256 \
  --size 128 --labels-out "$work/labels.png" -o "$work/mask_synth.png" || fail "mask synthetic"
"$bin" uvtools mask -q "$work/labels.png" --mesh "$work/t/face.obj" --size 128 -o "$work/mask_labels.png" || fail "mask labels"
"$bin" uvtools mask -q --mesh "$work/t/face.obj" --synthetic hair --landmarks "$lm" --seed 2 --image-size 256 --size 128 \
  -o "$work/mask_hair.png" || fail "mask hair"
$py - "$here/../python" "$work" <<'PY' || fail "mask"
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import read
w = sys.argv[2]
a, b, c = (read(f"{w}/{n}.png")[..., 0] for n in ("mask_synth", "mask_labels", "mask_hair"))
u = read(f"{w}/uv_confidence.png")[..., 0]  # the unobstructed front view at 256 (unwarp test above)
seen = u[::2, ::2] > 0
assert (a == b).all(), "labels written by --synthetic do not give the same mask back"
assert 0.2 * seen.sum() < a.sum() < 0.95 * seen.sum(), (a.sum(), seen.sum())
assert 0.2 * seen.sum() < c.sum() < 0.97 * seen.sum(), (c.sum(), seen.sum())
print(f"ok   mask: glasses + hand keep {a.sum() / seen.sum():.0%} and a fringe {c.sum() / seen.sum():.0%} of the seen texels")
PY
oiiotool "$work/labels.png" --ch 0,0,0 -o "$work/labels_rgb.png"
expect_failure 3 "one channel" "$work/bad_mask.png" -- \
  "$bin" uvtools mask -q "$work/labels_rgb.png" --mesh "$work/t/face.obj" -o "$work/bad_mask.png"

expect_error() {  # expect_error NAME NEEDLE bake-args...
  local name=$1 needle=$2
  shift 2
  expect_failure 3 "$needle" "$work/out_$name" -- bake "$@" -o "$work/out_$name"
}
broken() { cp -r "$maps" "$work/b_$1" && echo "$work/b_$1"; }
d=$(broken mixed)
oiiotool "$d/roughness.png" --resize 128x128 -o "$d/roughness.png"
expect_error mixed "roughness.png: is 128 wide" "$d" --sizes 64
d=$(broken square)
oiiotool "$d/diffuse.png" --resize 256x128 -o "$d/diffuse.png"
expect_error square "not square" "$d" --sizes 64
expect_error divide "100 does not divide" "$maps" --sizes 100
d=$(broken zero)
oiiotool "$d/normal.png" --mulc 0 --addc 0.5 -o "$d/normal.png"
expect_error zero "zero normal vector" "$d" --sizes 64
mkdir -p "$work/b_trunc"
oiiotool "$maps/diffuse.png" -d half -o "$work/full.exr"
head -c $(( $(stat -c %s "$work/full.exr") / 2 )) "$work/full.exr" > "$work/b_trunc/diffuse.exr"
expect_error trunc "diffuse.exr" "$work/b_trunc" --sizes 64
expect_error sizes "not a whole number" "$maps" --sizes 64,abc
# Without -q and --layout the refusal is still the only line (the no-layout note comes after a bake that worked).
mkdir -p "$work/b_cut"
head -c 2000 "$maps/diffuse.png" > "$work/b_cut/diffuse.png"
expect_failure 3 "b_cut/diffuse.png" "$work/out_cut" -- "$bin" uvtools bake "$work/b_cut" --sizes 64 -o "$work/out_cut"
expect_failure 4 "nothere: is not a folder" "$work/out_nothere" -- "$bin" uvtools bake "$work/nothere" -o "$work/out_nothere"

# mean: a map and a darker copy with a black corner, averaged in linear light with the black texels left out (numpy).
oiiotool "$maps/diffuse.png" --mulc 0.5 --fill:color=0,0,0 64x64+0+0 -o "$work/dark.png"
"$bin" uvtools mean -q "$maps/diffuse.png" "$work/dark.png" -o "$work/mean.png" || fail "mean"
$py - "$here/../python" "$maps/diffuse.png" "$work/dark.png" "$work/mean.png" <<'PY' || fail "mean oracle"
import sys
sys.path.insert(0, sys.argv[1])
import numpy as np
from bake_oracle import read
lin = lambda c: np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
srgb = lambda c: np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.maximum(c, 0) ** (1 / 2.4) - 0.055)
a, b = (lin(read(p)[..., :3]) for p in sys.argv[2:4])
ca, cb = ((m.sum(2, keepdims=True) > 1e-4).astype(float) for m in (a, b))
want = srgb((a * ca + b * cb) / np.maximum(ca + cb, 1))
err = 65535 * np.abs(read(sys.argv[4]) - want).max()
assert err <= 0.51, f"mean off by {err:.2f} / 65535"
print(f"ok   mean: max |ours - numpy| {err:.2f} / 65535 (16-bit in, 16-bit out)")
PY
expect_failure 3 "128/diffuse.png: is 128x128" "$work/mean_bad.png" -- \
  "$bin" uvtools mean -q "$maps/diffuse.png" "$work/png/128/diffuse.png" -o "$work/mean_bad.png"
echo "18 passed, 0 failed"
