# The shared prologue of the command-line tests. A test starts with
#   source "$(dirname "$0")/lib.sh" "$@"
# (its first argument is the bareskin binary) and gets:
#   bin   the binary;  here  tests/cli;  py  the system python3 (numpy, skimage);  work  a temporary folder, removed on
#   exit;  fail MESSAGE (prints FAIL: MESSAGE, exits 1);  error_ok / expect_failure (below).
set -u
bin=$(cd "$(dirname "$1")" && pwd)/$(basename "$1")  # absolute: some tests run from another folder
here=$(cd "$(dirname "${BASH_SOURCE[1]}")" && pwd)
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
  local t=$1 scans=$2 out=$3 s id
  shift 3
  local maps=("$@")
  [ ${#maps[@]} -eq 0 ] && maps=(diffuse.png)
  for s in "$scans"/subject_*; do
    id=$(basename "$s")
    mkdir -p "$out/$id"
    for m in "${maps[@]}"; do cp "$s/truth/maps/"$m "$out/$id/" || fail "copy $m"; done
    $py - "$here/../python" "$t/face.obj" "$s/truth/correspondence.safetensors" "$out/$id/mesh.obj" <<'PY' || fail "truth mesh"
import sys
sys.path.insert(0, sys.argv[1])
from safetensors_oracle import read_safetensors
P = read_safetensors(sys.argv[3])[1]["template_to_scan_point"]
out, k = [], 0
for line in open(sys.argv[2]):
    if line.startswith("vn "):
        continue
    if line.startswith("v "):
        line, k = "v %.7g %.7g %.7g\n" % tuple(P[k]), k + 1
    elif line.startswith("f "):  # the normals are dropped: so are the corners' references to them
        line = "f " + " ".join("/".join(c.split("/")[:2]) for c in line.split()[1:]) + "\n"
    out.append(line)
open(sys.argv[4], "w").writelines(out)
PY
  done
}

# tiny_face_world: the smallest world `texgen faces` draws from, in $work: a 3000-vertex template (t/), three
# synthetic scans (s/) registered from their truth with their diffuse, roughness and specular maps (r/), and a
# model built from them ($model = m/model.safetensors).
tiny_face_world() {
  "$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
  "$bin" scan synth -q --template "$work/t" --count 3 --vertices 6000 --res 64 --truth-res 64 -o "$work/s" \
    || fail "synth"
  register_truth "$work/t" "$work/s" "$work/r" diffuse.png roughness.png specular.png
  model="$work/m/model.safetensors"
  "$bin" mm-build -q --template "$work/t" --appearance-res 32 --registered "$work/r" -o "$model" || fail "mm-build"
}
