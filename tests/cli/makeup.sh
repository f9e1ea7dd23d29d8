#!/bin/bash
# makeup list/show/apply and relight on a small avatar folder (a 3000-vertex template's mesh, maps made by oiiotool):
# the folder written is complete and its GLB carries the made-up map, only a few texels change for a lipstick, a look
# file edited from `makeup show` applies, bad input (a missing map, a look with an unknown region or key, an unknown
# --region, an unreadable HDR) gets one line, exit 3 and no output; relight under a key light, an HDR and the
# photo's light, and the light export; makeup extract reads the lipstick back off the made-up map.
source "$(dirname "$0")/lib.sh" "$@"

"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
a=$work/avatar
mkdir -p "$a/maps"
cp "$work/t/face.obj" "$a/mesh.obj"
oiiotool --pattern noise:type=uniform:min=0.55:max=0.75 128x128 3 -d uint8 -o "$a/maps/diffuse.png" || fail "oiiotool"
oiiotool --pattern constant:color=0.5,0.5,1 128x128 3 -d uint8 -o "$a/maps/normal.png"
oiiotool --pattern constant:color=0.5 128x128 1 -d uint8 -o "$a/maps/roughness.png"
oiiotool --pattern constant:color=0.5 128x128 1 -d uint8 -o "$a/maps/specular.png"
cat > "$a/coefficients.json" <<'JSON'
{"alpha": [0], "beta": [0], "delta": [0], "rotation": [0, 0, 0], "translation": [0, 0, 0],
 "gamma": [0.8,0,0.3,0,0,0,0,0,0, 0.8,0,0.3,0,0,0,0,0,0, 0.8,0,0.3,0,0,0,0,0,0]}
JSON
export BARESKIN_TEMPLATE=$work/t

"$bin" makeup list | grep -q "red_lips" || fail "makeup list lacks red_lips"
"$bin" makeup list | grep -q "^  lips .*lip_centre" || fail "makeup list lacks the lips group"
"$bin" makeup apply -q "$a" --look red_lips -o "$work/red" || fail "makeup apply"
for f in avatar.glb mesh.obj maps/diffuse.png maps/normal.png maps/roughness.png maps/specular.png preview_light1.png \
  preview_light3.png before_after.png look.json makeup_layer.png makeup_report.json coefficients.json; do
  [ -s "$work/red/$f" ] || fail "makeup apply wrote no $f"
done
$py - "$a" "$work/red" <<'PY' || fail "made-up maps"
import sys
sys.path.insert(0, sys.argv[0].rsplit("/", 1)[0])
import numpy as np
from skimage import io
a, r = sys.argv[1], sys.argv[2]
before, after = io.imread(a + "/maps/diffuse.png").astype(int), io.imread(r + "/maps/diffuse.png").astype(int)
changed = (before != after).any(axis=-1).mean()
assert 0.001 < changed < 0.05, changed  # the lips only
red = (after - before)[(before != after).any(axis=-1)]
assert red[:, 0].mean() > red[:, 1].mean() + 20, red.mean(axis=0)  # towards red
glb = open(r + "/avatar.glb", "rb").read()
assert open(r + "/maps/diffuse.png", "rb").read() in glb, "the GLB does not embed the made-up diffuse map"
PY

# A look file edited from a built-in.
"$bin" makeup show red_lips | $py -c "
import json, sys
look = json.load(sys.stdin); look['name'] = 'pink'; look['layers'][0]['shade'] = 'pink'
json.dump(look, open('$work/pink.json', 'w'))" || fail "makeup show"
"$bin" makeup apply -q "$a" --look "$work/pink.json" --region lips -o "$work/pink" || fail "apply a look file"
grep -q '"pink"' "$work/pink/look.json" || fail "look.json is not the look file"

# makeup extract: the red_lips folder's diffuse against the bare one (both in the template UV) gives a lipstick
# layer, red, and nothing on the untouched regions; the look applies. Bad input: unwraps of two sizes, no makeup.
"$bin" makeup extract -q --made "$work/red/maps/diffuse.png" --bare "$a/maps/diffuse.png" -o "$work/ex.json" \
  --name ex || fail "makeup extract"
$py - "$work/ex.json" <<'PY' || fail "extracted look: $(cat "$work/ex.json")"
import json, sys
look = json.load(open(sys.argv[1]))
assert [l["region"] for l in look["layers"]] == ["lips"], look
c = look["layers"][0]["colour"]
r, g, b = (int(c[i:i + 2], 16) for i in (1, 3, 5))
assert r > g + 60 and r > b + 60, c  # red
PY
"$bin" makeup apply -q "$a" --look "$work/ex.json" -o "$work/ex" || fail "apply the extracted look"
oiiotool "$a/maps/diffuse.png" --resize 64x64 -o "$work/small.png"
expect_failure 3 "64 wide" "$work/ex2.json" -- "$bin" makeup extract -q --made "$work/red/maps/diffuse.png" \
  --bare "$work/small.png" -o "$work/ex2.json"
expect_failure 3 "no makeup found" "$work/ex3.json" -- "$bin" makeup extract -q --made "$a/maps/diffuse.png" \
  --bare "$a/maps/diffuse.png" -o "$work/ex3.json"

# Bad input: one line, exit 3, no output.
$py -c "
import json; look = json.load(open('$work/pink.json')); look['layers'][0]['region'] = 'ears'
json.dump(look, open('$work/ears.json', 'w'))
look = json.load(open('$work/pink.json')); look['layers'][0]['colr'] = '#ff0000'
json.dump(look, open('$work/key.json', 'w'))"
expect_failure 3 "layers[0].region" "$work/bad1" -- "$bin" makeup apply -q "$a" --look "$work/ears.json" -o "$work/bad1"
expect_failure 3 "layers[0].colr" "$work/bad2" -- "$bin" makeup apply -q "$a" --look "$work/key.json" -o "$work/bad2"
expect_failure 3 "'ears' is an unknown region" "$work/bad3" -- "$bin" makeup apply -q "$a" --region lips,ears -o "$work/bad3"
cp -r "$a" "$work/nomap" && rm "$work/nomap/maps/specular.png"
expect_failure 3 "specular.png" "$work/bad4" -- "$bin" makeup apply -q "$work/nomap" -o "$work/bad4"
echo "not an image" > "$work/bad.exr"
expect_failure 3 "bad.exr" "$work/bad5.png" -- "$bin" relight -q "$a" --env "$work/bad.exr" -o "$work/bad5.png"
oiiotool --pattern constant:color=1,1,1 64x64 3 -d half -o "$work/square.exr"
expect_failure 3 "square.exr" "$work/bad6.png" -- "$bin" relight -q "$a" --env "$work/square.exr" -o "$work/bad6.png"
expect_failure 3 "more than one light" "$work/bad7.png" -- "$bin" relight -q "$a" --env "$work/square.exr" \
  --direction 0,0,1 -o "$work/bad7.png"

# relight: a key light from the face's left and right, an HDR, the photo's light; the light export.
"$bin" relight -q "$work/red" --direction 1,0,0.3 --size 96 -o "$work/left.png" || fail "relight --direction"
"$bin" relight -q "$work/red" --direction -1,0,0.3 --size 96 -o "$work/right.png" || fail "relight --direction"
oiiotool --pattern constant:color=0.7,0.7,0.7 64x32 3 -d half -o "$work/env.exr"
"$bin" relight -q "$work/red" --env "$work/env.exr" --view 30,10 --size 96 -o "$work/env.png" || fail "relight --env"
"$bin" relight -q "$work/red" --size 96 -o "$work/photo.png" --export-light "$work/light" || fail "relight photo light"
$py - "$work" <<'PY' || fail "relight images or light files"
import json, subprocess, sys
import numpy as np
from skimage import io
w = sys.argv[1]
left, right = io.imread(w + "/left.png").astype(float), io.imread(w + "/right.png").astype(float)
cols = np.arange(left.shape[1])
cx = lambda im: (im[..., 1].sum(axis=0) * cols).sum() / im[..., 1].sum()
assert cx(left) > cx(right) + 3, (cx(left), cx(right))  # +x lights the image's right half
assert io.imread(w + "/env.png").max() > 50
sh = json.load(open(w + "/light/light_sh.json"))
assert len(sh) == 27 and abs(sh[0] - 0.8) < 1e-9
info = subprocess.run(["oiiotool", "--info", w + "/light/light_env.exr"], capture_output=True, text=True).stdout
assert "64 x   32" in info or "64 x 32" in info, info
PY
echo "makeup.sh: passed"
