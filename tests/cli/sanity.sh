#!/usr/bin/env bash
# Inputs that parse but make no sense, and hostile files: each refused with one line that says what to fix, exit 3,
# nothing written (docs/reliability.md). A 2-triangle scan; a scan in metres (and the same scan registered with
# --scale 1000); landmarks off the scan; hostile shards (a '../' member, a symbolic link, a hard link, a member whose
# header promises more than --max-memory); a 16x16 photo to `run` and `recon` (where the Torch side is built).
source "$(dirname "$0")/lib.sh" "$@"
"$bin" template -q --vertices 3000 -o "$work/t" || fail "template"
"$bin" scan synth -q --template "$work/t" --count 1 --vertices 6000 --res 64 --truth-res 64 -o "$work/s" || fail "synth"
reg() { "$bin" scan register -q --template "$work/t" --maps-res 64 "$@"; }
# broken NAME PYTHON: a copy of the scan folder changed by the Python snippet (d: the folder; V/lines: the OBJ).
broken() {
  mkdir -p "$work/b_$1"
  cp -r "$work/s/subject_0000" "$work/b_$1/"
  $py - "$work/b_$1/subject_0000" <<<"import json, sys
d = sys.argv[1]
$2" || fail "make $1"
}

broken two_triangles 'open(d + "/mesh.obj", "w").write("v 0 0 0\nv 100 0 0\nv 0 100 0\nv 100 100 0\nf 1 2 3\nf 2 4 3\n")'
expect_failure 3 "mesh.obj: has only 2 triangles (a face scan has 1000 or more)" "$work/o_two" -- \
  reg --scans "$work/b_two_triangles" -o "$work/o_two"

broken metres '
lines = []
for l in open(d + "/mesh.obj"):
    if l.startswith("v "):
        l = "v %.9g %.9g %.9g\n" % tuple(float(t) / 1000 for t in l.split()[1:4])
    lines.append(l)
open(d + "/mesh.obj", "w").writelines(lines)
lm = json.load(open(d + "/landmarks.json"))
lm["points"] = [[c / 1000 for c in p] for p in lm["points"]]
json.dump(lm, open(d + "/landmarks.json", "w"))'
expect_failure 3 "the scan looks like metres; rerun with --scale 1000" "$work/o_metres" -- \
  reg --scans "$work/b_metres" -o "$work/o_metres"
reg --scans "$work/b_metres" -o "$work/o_scaled" --scale 1000 \
  || fail "the metres scan with --scale 1000 did not register"
[ -f "$work/o_scaled/subject_0000/report.json" ] || fail "no report for the scaled scan"

broken off_scan '
lm = json.load(open(d + "/landmarks.json"))
lm["points"] = [[p[0] + 500, p[1], p[2]] for p in lm["points"]]
json.dump(lm, open(d + "/landmarks.json", "w"))'
expect_failure 3 "landmarks.json: landmark 0 lies" "$work/o_off" -- reg --scans "$work/b_off_scan" -o "$work/o_off"
grep -qF "outside the scan's bounding box" "$work/err" || fail "off-scan landmarks: $(cat "$work/err")"

# Hostile shards, made by Python's tarfile (as a downloaded dataset could be): refused naming the member.
$py - "$work" <<'PY' || fail "hostile tars"
import io, sys, tarfile
w = sys.argv[1]
def shard(name, *members):
    with tarfile.open(f"{w}/{name}.tar", "w", format=tarfile.USTAR_FORMAT) as t:
        good = tarfile.TarInfo("000000.json"); good.size = 2
        t.addfile(good, io.BytesIO(b"{}"))
        for m, data in members:
            t.addfile(m, io.BytesIO(data) if data is not None else None)
up = tarfile.TarInfo("../000001.json"); up.size = 2
shard("up", (up, b"{}"))
sym = tarfile.TarInfo("000001.json"); sym.type = tarfile.SYMTYPE; sym.linkname = "/etc/passwd"
shard("symlink", (sym, None))
hard = tarfile.TarInfo("000001.json"); hard.type = tarfile.LNKTYPE; hard.linkname = "000000.json"
shard("hardlink", (hard, None))
PY
expect_failure 3 "member '../000001.json' has a name that leaves the shard's folder" "$work/up.png" -- \
  "$bin" texgen show "$work/up.tar" -o "$work/up.png"
expect_failure 3 "member '000001.json' is a link" "$work/sym.png" -- "$bin" texgen show "$work/symlink.tar" -o "$work/sym.png"
expect_failure 3 "member '000001.json' is a link" "$work/hard.png" -- "$bin" texgen show "$work/hardlink.tar" -o "$work/hard.png"
# A member of 3 MB read under --max-memory 1M: refused before it is allocated, naming the flag.
$py - "$work" <<'PY' || fail "big tar"
import io, sys, tarfile
with tarfile.open(sys.argv[1] + "/big.tar", "w", format=tarfile.USTAR_FORMAT) as t:
    m = tarfile.TarInfo("000000.makeup.png"); m.size = 3000000
    t.addfile(m, io.BytesIO(bytes(3000000)))
PY
expect_failure 3 "member '000000.makeup.png' needs 0.003 GB, more than the memory limit of 0.001 GB" "$work/big.png" -- \
  "$bin" --max-memory 1M texgen show "$work/big.tar" -o "$work/big.png"
expect_failure 3 "--max-memory: '1.5G' is not a memory size" "$work/big.png" -- \
  "$bin" --max-memory 1.5G texgen show "$work/big.tar" -o "$work/big.png"

# A 16x16 photo, refused before any network or model is loaded (those named here do not exist).
$py -c "import numpy as np, skimage.io as io; io.imsave('$work/tiny.png', np.full((16, 16, 3), 128, np.uint8))" \
  || fail "tiny photo"
if "$bin" run --help > /dev/null 2>&1; then
  expect_failure 3 "tiny.png: is 16x16 pixels; a face photo needs at least 64 on its shorter side" "$work/o_run" -- \
    "$bin" run "$work/tiny.png" --model m --texture tex --no-bareskin -o "$work/o_run"
  expect_failure 3 "tiny.png: is 16x16 pixels" "$work/o_recon" -- "$bin" recon "$work/tiny.png" --run F -o "$work/o_recon"
fi
echo "sanity: all refused"
