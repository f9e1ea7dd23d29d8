#!/usr/bin/env bash
# texgen ingest-pairs on skimage's astronaut with a synthetic "after" (a colour change of the lower face): one face
# sample with the before/after pair aligned alike, masks that leave the lips out, "has_truth": false and no truth
# members (read back with Python's tarfile); texgen show draws it with n/a tiles for the absent members. Bad input:
# an unmatched photo, a photo without a face, a corrupt photo, a folder that is no shard set -> one line, exit 3,
# nothing written; an output folder that cannot be made -> exit 4.
source "$(dirname "$0")/lib.sh" "$@"
export BARESKIN_ASSETS=${BARESKIN_ASSETS:-$here/../../assets}
astronaut=/usr/lib/python3/dist-packages/skimage/data/astronaut.png
[ -f "$astronaut" ] || fail "$astronaut missing (Debian python3-skimage; make deps)"
mkdir -p "$work/before" "$work/after" "$work/flat_b" "$work/flat_a"
cp "$astronaut" "$work/before/astronaut.png"
$py - "$astronaut" "$work" <<'PY' || fail "making the after photo"
import sys
import numpy as np
from skimage import io
img = io.imread(sys.argv[1]).astype(np.float64)
after = img.copy()
after[300:, :, 0] = np.minimum(255, after[300:, :, 0] * 1.15)  # warmer, darker lower face: a "makeup" colour change
after[300:, :, 2] *= 0.85
io.imsave(sys.argv[2] + "/after/astronaut.jpg", after.astype(np.uint8), quality=95, check_contrast=False)
flat = np.full((256, 256, 3), 128, np.uint8)
io.imsave(sys.argv[2] + "/flat_b/flat.png", flat, check_contrast=False)
io.imsave(sys.argv[2] + "/flat_a/flat.png", flat, check_contrast=False)
PY

# 1. The pair (stems match across extensions) -> one sample.
"$bin" texgen ingest-pairs -q "$work/before" "$work/after" -o "$work/real" || fail "ingest-pairs astronaut"
$py - "$work/real" <<'PY' || fail "the ingested shard"
import io as bio, json, sys, tarfile
import numpy as np
from skimage import io
from skimage.draw import polygon
root = sys.argv[1]
manifest = json.load(open(root + "/manifest.json"))
assert manifest["samples"] == 1 and manifest["metadata"]["has_truth"] is False, manifest
members = {}
with tarfile.open(root + "/" + manifest["shards"][0]["name"]) as tar:
    for m in tar.getmembers():
        members[m.name] = tar.extractfile(m).read()
names = sorted(members)
assert names == ["00000000.before.png", "00000000.face.png", "00000000.json", "00000000.makeup.png",
                 "00000000.skin.png"], names
meta = json.loads(members["00000000.json"])
assert meta["has_truth"] is False and meta["style"] == "unknown" and meta["subject"] == "real/astronaut", meta
after = np.array(meta["landmarks"]); before = np.array(meta["before"]["landmarks"])
assert after.shape == (68, 2) and (after > 0).all() and (after < 256).all(), after
# Same face, a colour change only: both photos align alike (landmarks within 2 px in the aligned frame).
d = np.abs(after - before).max()
print(f"  aligned landmarks before vs after: max {d:.2f} px")
assert d < 2.0, d
makeup = io.imread(bio.BytesIO(members["00000000.makeup.png"]))
skin = io.imread(bio.BytesIO(members["00000000.skin.png"]))
assert makeup.shape == (256, 256, 3) and skin.shape == (256, 256), (makeup.shape, skin.shape)
# Skin: the lips (48-59) and the eyes (36-41, 42-47) are out; most of the cheeks are in.
for ids in (range(48, 60), range(36, 42), range(42, 48)):
    rr, cc = polygon(after[list(ids), 1] - 0.5, after[list(ids), 0] - 0.5, skin.shape)
    assert skin[rr, cc].mean() < 0.05 * 255, ids
cheek = np.mean(after[[1, 2, 31, 41]], axis=0)
r, c = int(cheek[1]), int(cheek[0])
assert skin[r - 4:r + 5, c - 4:c + 5].mean() > 0.8 * 255, skin[r - 4:r + 5, c - 4:c + 5]
report = json.load(open(root + "/report.json"))
assert report["pairs"] == 1 and report["written"] == 1 and not report["unmatched"], report
PY

# 2. texgen show: 5 columns of 256², a header, the bare column an n/a tile (grey).
"$bin" texgen show -q "$work/real" -o "$work/sheet.png" --count 4 || fail "texgen show"
$py - "$work/sheet.png" <<'PY' || fail "the sheet"
import sys
import numpy as np
from skimage import io
s = io.imread(sys.argv[1])
assert s.shape[1] == 5 * 256 and (s.shape[0] - 256) in range(16, 64), s.shape
top = s.shape[0] - 256
bare = s[top:, 2 * 256:3 * 256]
assert np.median(bare) in (127, 128) and (np.abs(bare[:60].astype(int) - 128) <= 1).all(), "bare tile is not n/a grey"
marks = s[top:, 4 * 256:]
green = (marks[..., 1] > 240) & (marks[..., 0] < 40) & (marks[..., 2] < 40)
assert green.sum() > 68 * 4, green.sum()  # the landmarks are drawn
PY
[ "$(ls -A "$work" | grep -c '^\.')" -eq 0 ] || fail "temporaries left behind"

# 3. Bad input: an unmatched photo (without --keep-going), a photo without a face, a folder that is no shard set.
cp "$astronaut" "$work/after/lonely.png"
expect_failure 3 "lonely.png" "$work/bad" -- "$bin" texgen ingest-pairs -q "$work/before" "$work/after" -o "$work/bad"
"$bin" texgen ingest-pairs -q --keep-going "$work/before" "$work/after" -o "$work/kept" || fail "--keep-going"
grep -q lonely.png "$work/kept/report.json" || fail "the unmatched photo is not listed"
expect_failure 3 "no face found" "$work/bad" -- "$bin" texgen ingest-pairs -q "$work/flat_b" "$work/flat_a" -o "$work/bad"
# With --keep-going the faceless pair is listed (a warning) and, with no pair left, the run fails all the same.
"$bin" texgen ingest-pairs -q --keep-going "$work/flat_b" "$work/flat_a" -o "$work/bad" 2> "$work/err"
code=$?
[ $code -eq 3 ] && tail -1 "$work/err" | grep -qF "no pair has a face" && grep -qF "flat.png: no face found" "$work/err" \
  && [ ! -e "$work/bad" ] || fail "--keep-going without any face -> exit $code: $(cat "$work/err")"
expect_failure 3 "not a shard set" "$work/bad.png" -- "$bin" texgen show -q "$work/before" -o "$work/bad.png"
# A corrupt photo: an error naming it, or listed and skipped with --keep-going; an output that cannot be made: exit 4.
rm "$work/after/lonely.png"
echo "not an image" > "$work/before/broken.png"
cp "$astronaut" "$work/after/broken.png"
expect_failure 3 "broken.png" "$work/bad" -- "$bin" texgen ingest-pairs -q "$work/before" "$work/after" -o "$work/bad"
"$bin" texgen ingest-pairs -q --keep-going "$work/before" "$work/after" -o "$work/kept2" 2> /dev/null \
  || fail "--keep-going over a corrupt photo"
grep -q broken.png "$work/kept2/report.json" || fail "the corrupt photo is not listed"
expect_failure 4 "/proc" "" -- "$bin" texgen ingest-pairs -q "$work/before" "$work/after" -o /proc/bareskin/real
[ "$(ls -A "$work" | grep -c '^\.')" -eq 0 ] || fail "temporaries left behind"
echo "texgen ingest-pairs / show: ok"
