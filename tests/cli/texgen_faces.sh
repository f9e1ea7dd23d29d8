#!/usr/bin/env bash
# texgen faces through the command line, on a tiny world: three synthetic scans "registered" from their truth and a
# model built from them, plus 3DMM subjects.
# - the shards, read by Python's tarfile: every member at its size, json fields, manifests whose counts and CRC-32
#   agree with the tar files, no subject in two splits;
# - the same seed gives the same bytes: a run killed with -9 mid-run and resumed equals an uninterrupted run;
# - bad input, one line each, exit 3/4, no output: a registered subject without its diffuse map, a model file of another format,
#   --count 0, an unwritable output folder.
source "$(dirname "$0")/lib.sh" "$@"
tiny_face_world
args=(texgen faces -q --threads 2 --registered "$work/r" --model "$model" --mm-subjects 5 --val 1 --test 2 --seed 3
  --align truth --map-size 64 --layer-size 32 --backgrounds "")
make() {  # make OUT [flags...]
  local out=$1
  shift
  "$bin" "${args[@]}" -o "$out" "$@"
}
make "$work/a" --count 24 --shard-size 2 || fail "texgen faces"

$py - "$work/a" <<'PY' || fail "shards"
import io, json, sys, tarfile, zlib
import numpy as np
from skimage import io as skio
root = sys.argv[1]
subjects = {}
for split in ("train", "val", "test"):
    m = json.load(open(f"{root}/{split}/manifest.json"))
    n = 0
    for shard in m["shards"]:
        path = f"{root}/{split}/{shard['name']}"
        assert zlib.crc32(open(path, "rb").read()) == shard["crc32"], path
        groups = {}
        with tarfile.open(path) as tar:
            for member in tar.getmembers():
                key, suffix = member.name.split(".", 1)
                groups.setdefault(key, {})[suffix] = tar.extractfile(member).read()
        assert len(groups) == shard["samples"], path
        for key, g in groups.items():
            n += 1
            meta = json.loads(g["json"])
            assert meta["split"] == split and meta["has_truth"] is True
            assert subjects.setdefault(meta["subject"], split) == split, meta["subject"] + " is in two splits"
            for name, shape in (("makeup.png", (256, 256, 3)), ("before.png", (256, 256, 3)), ("bare.png", (256, 256, 3)),
                                ("skin.png", (256, 256)), ("face.png", (256, 256)), ("layer.png", (32, 32, 4)),
                                ("finish.png", (32, 32, 2))):
                a = skio.imread(io.BytesIO(g[name]))
                # PNG colour types: 0 grey, 2 RGB, 4 grey + alpha, 6 RGBA (skimage widens grey + alpha to RGBA)
                kind = {0: 1, 2: 3, 4: 2, 6: 4}[g[name][25]]
                assert a.shape[:2] == shape[:2] and kind == (shape[2] if len(shape) == 3 else 1), (name, a.shape, kind)
            skin, face = skio.imread(io.BytesIO(g["skin.png"])), skio.imread(io.BytesIO(g["face.png"]))
            assert ((skin > 0) <= (face > 0)).all(), "skin outside the face"
            assert len(meta["landmarks"]) == 68 and len(meta["landmarks_visible"]) == 68
            c = meta["coefficients"]
            assert len(c["gamma"]) == 27 and len(c["rotation"]) == 3 and len(c["translation"]) == 3
            assert meta["align"]["source"] == "truth" and len(meta["align"]["similarity"]) == 2
    assert n == m["samples"], (split, n, m["samples"])
assert sum(1 for s in subjects if s.startswith("scan/")) == 3 and sum(1 for s in subjects if s.startswith("mm/")) == 5
PY

# kill -9 mid-run, then resume: the same bytes as the uninterrupted run. The binary itself runs in the background (a
# shell function run with & is a subshell: kill -9 would end the subshell and leave the binary writing beside the resume).
"$bin" "${args[@]}" -o "$work/b" --count 24 --shard-size 2 > /dev/null 2>&1 &
pid=$!
for _ in $(seq 1 600); do
  ls "$work"/b/*/faces-*.tar > /dev/null 2>&1 && break
  sleep 0.02
done
kill -9 "$pid" 2> /dev/null
wait "$pid" 2> /dev/null
[ "$(ls "$work"/b/*/faces-*.tar 2> /dev/null | wc -l)" -lt "$(ls "$work"/a/*/faces-*.tar | wc -l)" ] \
  || fail "the run finished before it was killed"
make "$work/b" --count 24 --shard-size 2 || fail "resume"
for f in $(cd "$work/a" && ls */*.tar */manifest.json); do cmp -s "$work/a/$f" "$work/b/$f" || fail "b/$f differs"; done
[ "$(cd "$work/b" && ls */*.tar | wc -l)" -eq "$(cd "$work/a" && ls */*.tar | wc -l)" ] || fail "shard count"
[ -z "$(ls -A "$work"/b/train | grep partial)" ] || fail "a partial shard was left"

# Bad input: one line, exit 3 (4 for the folder), nothing written.
cp -r "$work/r" "$work/r_nomap"
rm "$work/r_nomap/subject_0001/diffuse.png"  # (roughness and specular are filled: tests/cli/third_party.sh)
nomap=("${args[@]}")
nomap[6]="$work/r_nomap"
expect_failure 3 "has no diffuse map" "$work/bad1" -- "$bin" "${nomap[@]}" --count 4 -o "$work/bad1"
expect_failure 3 "$work/t/face.obj" "$work/bad2" -- "$bin" texgen faces -q --model "$work/t/face.obj" --count 4 \
  --align truth -o "$work/bad2"
expect_failure 3 "--count" "$work/bad3" -- "$bin" "${args[@]}" --count 0 -o "$work/bad3"
expect_failure 4 "/proc" "" -- "$bin" "${args[@]}" --count 4 -o /proc/bareskin/faces
echo "texgen faces: OK"
