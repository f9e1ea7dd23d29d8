#!/usr/bin/env bash
# cmake --install into a temporary prefix: the binaries and the links, the assets with their licences (without the
# tests' JavaScript bundle), the docs and a default template under share/bareskin. Then the installed tool, run from /
# with neither BARESKIN_ASSETS nor BARESKIN_TEMPLATE set, makes a small population of scans, registers it, builds a
# model and renders it: everything it needs is found beside the executable.
source "$(dirname "$0")/lib.sh" "$@"
build=$2
prefix=$work/prefix
BARESKIN_INSTALL_TEMPLATE_VERTICES=3000 cmake --install "$build" --prefix "$prefix" > "$work/install.log" 2>&1 \
  || fail "cmake --install: $(tail -5 "$work/install.log")"
share=$prefix/share/bareskin
for f in bin/bareskin bin/render bin/scan bin/uvtools share/bareskin/assets/mediapipe_face_mesh/NOTICE \
         share/bareskin/assets/human/LICENSE share/bareskin/template/face.obj share/bareskin/template/landmarks.json \
         share/bareskin/doc/README.md share/bareskin/doc/cli.md share/bareskin/doc/architecture.md; do
  [ -e "$prefix/$f" ] || fail "not installed: $f"
done
# Where the Torch side is built, bareskin hands the commands that reach it (scan, mm-build below) to bareskin-torch.
if [ -e "$build/bin/bareskin-torch" ]; then
  [ -x "$prefix/bin/bareskin-torch" ] || fail "not installed: bin/bareskin-torch"
fi
if [ -d "$share/assets/face_api" ]; then
  [ -f "$share/assets/face_api/LICENSE" ] || fail "face_api installed without its licence"
  [ ! -e "$share/assets/face_api/dist" ] || fail "the tests' JavaScript bundle was installed"
fi
run() { (cd / && env -u BARESKIN_ASSETS -u BARESKIN_TEMPLATE PATH="$prefix/bin:/usr/bin:/bin" "$@"); }
run bareskin --version | grep -q "^bareskin " || fail "installed --version"
run bareskin scan synth -q --count 3 --vertices 6000 --res 64 -o "$work/scans" || fail "installed scan synth"
run scan register -q --maps-res 64 --scans "$work/scans" -o "$work/registered" || fail "installed scan register"
run bareskin mm-build -q "$work/scans" --registered "$work/registered" --appearance-res 32 -o "$work/model.safetensors" \
  || fail "installed mm-build"
echo '{"alpha": [1]}' > "$work/c.json"
run render -q --model "$work/model.safetensors" --coeffs "$work/c.json" --camera pinhole --size 64 -o "$work/face.png" \
  || fail "installed render"
$py - "$work" "$share/template/face.obj" <<'PY' || fail "results"
import json, sys
work, template = sys.argv[1], sys.argv[2]
m = json.load(open(f"{work}/scans/manifest.json"))
assert m["template"] == template.rsplit("/", 1)[0], m["template"]  # the installed template was used
rows = json.load(open(f"{work}/registered/summary.json"))["scans"]
assert len(rows) == 3 and all(r["correspondence_error_mm"]["median"] < 2.5 for r in rows), rows
b = json.load(open(f"{work}/model.build.json"))
assert b["subjects"] == 3 and b["components"]["appearance"] == 2, b
medians = ", ".join(f"{r['correspondence_error_mm']['median']:.2f}" for r in rows)
print(f"ok   installed tool from /: 3 scans registered (correspondence medians {medians} mm), model built, rendered")
PY
