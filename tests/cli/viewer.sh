#!/bin/bash
# The offline viewer in a real browser: headless Chromium (Debian's chromium) driven over its DevTools pipe by
# tests/node/viewer_check.mjs opens a made-up avatar's viewer.html from file:// in four states. The page loads with no
# console error or exception and says "ready"; the canvas is not blank; bare → red_lips changes the lips and not the
# forehead; a key light from the face's right then its left brightens that side of the image. Exits 77 (skipped, one
# line) where chromium or node is not installed.
source "$(dirname "$0")/lib.sh" "$@"
chrome=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$chrome" ] || ! command -v node > /dev/null; then
  echo "SKIP: no chromium or node on PATH (apt-get install chromium nodejs); the viewer's browser test did not run"
  exit 77
fi
[ -f "${BARESKIN_ASSETS:-}/three/three.module.min.js" ] || fail "no three.js in BARESKIN_ASSETS (scripts/fetch_assets.sh)"

"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
a=$work/avatar
mkdir -p "$a/maps"
cp "$work/t/face.obj" "$a/mesh.obj"
oiiotool --pattern noise:type=uniform:min=0.6:max=0.7 256x256 3 --mulc 1,0.82,0.72 -d uint8 -o "$a/maps/diffuse.png"
oiiotool --pattern constant:color=0.5,0.5,1 256x256 3 -d uint8 -o "$a/maps/normal.png"
oiiotool --pattern constant:color=0.6 256x256 1 -d uint8 -o "$a/maps/roughness.png"
oiiotool --pattern constant:color=0.5 256x256 1 -d uint8 -o "$a/maps/specular.png"
cat > "$a/coefficients.json" <<'JSON'
{"alpha": [0], "beta": [0], "delta": [0], "rotation": [0, 0, 0], "translation": [0, 0, 0],
 "gamma": [0.8,0,0.3,-0.2,0,0,0,0,0, 0.75,0,0.3,-0.2,0,0,0,0,0, 0.7,0,0.3,-0.2,0,0,0,0,0]}
JSON
BARESKIN_TEMPLATE=$work/t "$bin" makeup apply -q "$a" --look red_lips -o "$work/red" || fail "makeup apply"
[ -s "$work/red/viewer.html" ] || fail "makeup apply wrote no viewer.html"
grep -q "https\?://" "$work/red/viewer.html" && fail "viewer.html refers to the network"
"$bin" viewer -q "$a" --look "$work/red" || fail "bareskin viewer"
[ -s "$a/viewer.html" ] || fail "bareskin viewer wrote no page"

mkdir -p "$work/shots"
timeout 50 node "$here/../node/viewer_check.mjs" "$chrome" "$work/red/viewer.html" "$work/shots" \
  "variant=bare&az=0&el=0" "variant=red_lips&az=0&el=0" "variant=bare&az=-70&el=0" "variant=bare&az=70&el=0" \
  > "$work/report.json" || fail "viewer_check.mjs: $(tail -3 "$work/report.json")"
$py - "$work/report.json" <<'PY' || fail "viewer in the browser"
import json, sys
import numpy as np
from skimage import io
r = json.load(open(sys.argv[1]))
assert not r["errors"], r["errors"]
assert [s["status"] for s in r["states"]] == ["ready"] * 4, r["states"]
bare, lips, right, left = (io.imread(s["canvas"])[..., :3].astype(int) for s in r["states"])
face = np.abs(bare - np.array([32, 32, 32])).max(axis=-1) > 6  # the background is #202020
assert face.mean() > 0.1, f"the canvas is blank: {face.mean():.3f} of it shows the face"
rows, cols = np.nonzero(face)
top, height = rows.min(), rows.max() - rows.min()
changed = np.abs(lips - bare).max(axis=-1) > 8
band = lambda a, b: changed[top + int(a * height):top + int(b * height)][face[top + int(a * height):top + int(b * height)]]
forehead, mouth = band(0.05, 0.3), band(0.6, 0.9)
assert forehead.mean() < 0.002, f"the lipstick changed {forehead.mean():.4f} of the forehead"
assert mouth.mean() > 0.01, f"the lipstick changed only {mouth.mean():.4f} of the mouth band"
assert (lips - bare)[changed][:, 0].mean() > 5, "the lips did not turn redder"
mid = (cols.min() + cols.max()) // 2
lum = lambda im, half: im[..., 1][face & (np.arange(im.shape[1]) < mid if half == "l" else np.arange(im.shape[1]) >= mid)].mean()
assert lum(right, "l") > lum(right, "r") + 10, (lum(right, "l"), lum(right, "r"))  # light from −x: the image's left
assert lum(left, "r") > lum(left, "l") + 10, (lum(left, "l"), lum(left, "r"))
print(f"viewer: face {face.mean():.2f} of the canvas; lipstick changed {mouth.mean():.3f} of the mouth band, "
      f"{forehead.mean():.4f} of the forehead")
PY
echo "viewer.sh: passed"
