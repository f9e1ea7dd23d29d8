#!/usr/bin/env bash
# Stability of the recovered albedo (the issue's measure): per held-out subject, many makeup × light conditions of the
# same face; each condition's albedo is recovered in the template UV through F's fit (`bareskin demakeup --aligned`:
# G → F → unwrap), with BareSkinNet and without it (--without-g: the input itself through the same fit and
# unwrap), and the bare truth through the same path as the floor. Per texel, the standard deviation over a subject's
# conditions (sRGB, 0-255, mean of R, G, B) on the texels every condition sees, averaged over the face UV and over the
# subjects. Goal: ≥ 60% lower with G.
#   bash bench/bareskinnet_stability.sh <bin> <faces split/> <bsn run> <out/> [uv size] [truth]
# (truth = 1 adds two more passes: the bare truth through the same path, the floor of the fit and unwrap; and the
# before images (light, no makeup) without G, the spread the light alone causes. A 7th argument, a `texgen faces`
# world with a train split, adds the level oracle: each bare truth at the level a predictor fitted on that world
# reads from the makeup photo (bench/bareskin_ceiling.py), through the same path: what a G with every detail right
# but the light's level only as well guessed as one photo tells would leave.)
# The faces split holds the subjects (e.g. texgen faces --mm-subjects 4 --test 3 --count 120 --seed 77 with poses
# fixed: 30 conditions per test subject; a new seed gives identities no run has trained on).
set -euo pipefail
bin=$1 split=$2 run=$3 out=$4 uv=${5:-256} truth=${6:-0} level_world=${7:-}
variants=(without with)
[ "$truth" = 1 ] && variants+=(truth light)
[ -n "$level_world" ] && variants+=(level)
py=/usr/bin/python3
mkdir -p "$out"
"$py" - "$split" "$out/inputs" <<'PY'
import glob, json, os, sys, tarfile
split, dst = sys.argv[1:3]
for shard in sorted(glob.glob(os.path.join(split, "*.tar"))):
    with tarfile.open(shard) as tar:
        members = {m.name: m for m in tar.getmembers() if m.isfile()}
        for name, m in members.items():
            if not name.endswith(".json"):
                continue
            key = name[:-len(".json")]
            meta = json.load(tar.extractfile(m))
            subject = meta["subject"].replace("/", "_")
            for kind in ("makeup", "bare", "before"):
                d = os.path.join(dst, kind, subject)
                os.makedirs(d, exist_ok=True)
                with open(os.path.join(d, key + ".png"), "wb") as f:
                    f.write(tar.extractfile(members[f"{key}.{kind}.png"]).read())
PY
if [ -n "$level_world" ] && [ ! -d "$out/inputs/level" ]; then
  "$py" "$(dirname "$0")/bareskin_ceiling.py" "$level_world" --level-oracle "$split" "$out/inputs/level.tmp"
  mv "$out/inputs/level.tmp" "$out/inputs/level"
fi
for subject in "$out"/inputs/makeup/*/; do
  s=$(basename "$subject")
  for variant in "${variants[@]}"; do
    dst="$out/$variant/$s"
    [ -d "$dst" ] && continue
    src="$out/inputs/makeup/$s"
    flags=()
    [ "$variant" = with ] || flags=(--without-g)
    [ "$variant" = truth ] && src="$out/inputs/bare/$s"
    [ "$variant" = light ] && src="$out/inputs/before/$s"
    [ "$variant" = level ] && src="$out/inputs/level/$s"
    "$bin" -q --threads 2 demakeup "$src" --aligned --run "$run" -o "$dst.tmp" --uv-size "$uv" "${flags[@]}"
    mv "$dst.tmp" "$dst"
  done
done
"$py" - "$out" <<'PY'
import glob, os, sys
import numpy as np
from skimage import io
out = sys.argv[1]
rows = {}
for variant in ("without", "with", "truth", "light", "level"):
    if not os.path.isdir(os.path.join(out, variant)):
        continue
    per_subject = {}
    for d in sorted(glob.glob(os.path.join(out, variant, "*"))):
        if d.endswith(".tmp"):  # an unfinished subject
            continue
        uvs = [io.imread(os.path.join(c, "uv.png"))[..., :3].astype(np.float64) for c in sorted(glob.glob(d + "/*/"))]
        seen = [io.imread(os.path.join(c, "uv_mask.png")) > 127 for c in sorted(glob.glob(d + "/*/"))]
        common = np.logical_and.reduce(seen)
        std = np.stack(uvs).std(0).mean(-1)  # per texel over the conditions, mean of R, G, B
        per_subject[os.path.basename(d)] = (float(std[common].mean()), int(common.sum()), len(uvs))
    rows[variant] = per_subject
subjects = sorted(set(rows["without"]) & set(rows["with"]))
print("| subject | conditions | texels | std without G | std with G | change | light only (before, without G) | bare truth (floor) | level oracle |")
print("|---|---|---|---|---|---|---|---|---|")
for s in subjects:
    a, n, c = rows["without"][s]
    b = rows["with"][s][0]
    t = f"{rows['truth'][s][0]:.2f}" if "truth" in rows else "—"
    li = f"{rows['light'][s][0]:.2f}" if "light" in rows and s in rows["light"] else "—"
    lv = "—"
    if "level" in rows and s in rows["level"]:
        lv = f"{rows['level'][s][0]:.2f} ({100 * (rows['level'][s][0] - a) / a:+.0f}%)"
    print(f"| {s} | {c} | {n} | {a:.2f} | {b:.2f} | {100 * (b - a) / a:+.0f}% | {li} | {t} | {lv} |")
a = np.mean([rows["without"][s][0] for s in subjects])
b = np.mean([rows["with"][s][0] for s in subjects])
t = f"{np.mean([rows['truth'][s][0] for s in subjects]):.2f}" if "truth" in rows else "—"
li = f"{np.mean([rows['light'][s][0] for s in subjects]):.2f}" if "light" in rows else "—"
lv = np.mean([rows["level"][s][0] for s in subjects]) if "level" in rows else None
lv = f"{lv:.2f} ({100 * (lv - a) / a:+.0f}%)" if lv is not None else "—"
print(f"| mean | | | {a:.2f} | {b:.2f} | {100 * (b - a) / a:+.0f}% (goal −60%) | {li} | {t} | {lv} |")
PY
