#!/usr/bin/env bash
# render --camera through the command line: three views x four passes from one call, the mask agrees with the
# colour's background, a weak-perspective camera and an SH file work; bad input (several views without {view}, an SH
# file without 27 numbers, a NaN vertex, --draw-landmarks without landmark vertices) gets one line and exit 3, and no
# image; --draw-landmarks draws at the points --landmarks-out writes.
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
mesh=$work/t/face.obj
"$bin" render -q "$mesh" --camera pinhole --views front,left,right --passes colour,albedo,depth,mask --size 96 \
  -o "$work/r_{view}_{pass}.png" || fail "render"
for v in front left right; do
  for p in colour albedo depth mask; do [ -f "$work/r_${v}_${p}.png" ] || fail "missing ${v}_${p}"; done
done
/usr/bin/python3 - "$work" "$(cd "$(dirname "$0")" && pwd)/../python" <<'PY' || fail "mask vs colour"
import sys
sys.path.insert(0, sys.argv[2])
from bake_oracle import read
for v in ("front", "left", "right"):
    c, m = read(f"{sys.argv[1]}/r_{v}_colour.png"), read(f"{sys.argv[1]}/r_{v}_mask.png")
    m = m[..., 0]
    assert 0.15 < (m > 0.5).mean() < 0.9, (v, (m > 0.5).mean())
    assert (c[m < 0.5] == 0).all() and (c[m > 0.5].max(axis=-1) > 0).mean() > 0.99, v
PY
# --draw-landmarks: the drawn pixels sit at the landmarks --landmarks-out projects, the mask pass is untouched.
"$bin" render -q "$mesh" --landmarks "$work/t/landmarks.json" --camera pinhole --size 96 --passes colour,mask \
  --draw-landmarks --landmarks-out "$work/lm.json" -o "$work/d_{pass}.png" || fail "draw landmarks"
/usr/bin/python3 - "$work" "$(cd "$(dirname "$0")" && pwd)/../python" <<'PY' || fail "drawn landmarks"
import json, sys
sys.path.insert(0, sys.argv[2])
from bake_oracle import read
w = sys.argv[1]
plain, drawn = read(f"{w}/r_front_colour.png"), read(f"{w}/d_colour.png")
changed = abs(drawn - plain).max(axis=-1) > 0.05
pts = json.load(open(f"{w}/lm.json"))["points"]
assert len(pts) == 68
near = [changed[max(0, int(y) - 1):int(y) + 2, max(0, int(x) - 1):int(x) + 2].any() for x, y in pts]
assert sum(near) >= 60, sum(near)
assert (read(f"{w}/d_mask.png") == read(f"{w}/r_front_mask.png")).all()
PY
echo '[0.8,0,0,0,0,0,0,0,0, 0.8,0,0,0,0,0,0,0,0, 0.8,0,0,0,0,0,0,0,0]' > "$work/sh.json"
"$bin" render -q "$mesh" --camera weak --sh "$work/sh.json" --size 64 -o "$work/weak.png" || fail "weak + sh file"
expect_error() {  # expect_error NAME NEEDLE render-args...
  local name=$1 needle=$2
  shift 2
  expect_failure 3 "$needle" "$work/bad_$name.png" -- "$bin" render -q "$@" -o "$work/bad_$name.png"
}
expect_error views "{view}" "$mesh" --camera pinhole --views front,left
echo '[1, 2, 3]' > "$work/short.json"
expect_error sh "27 numbers" "$mesh" --camera pinhole --sh "$work/short.json"
sed '0,/^v /s/^v [^ ]*/v nan/' "$mesh" > "$work/nan.obj"
expect_error nan "nan.obj" "$work/nan.obj" --camera pinhole
expect_error no_landmarks "68 landmark vertices" "$mesh" --camera pinhole --draw-landmarks
echo "8 passed, 0 failed"
