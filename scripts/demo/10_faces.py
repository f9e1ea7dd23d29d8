"""Demo §10's report fragment: contact sheets, makeup strength per style, the detector check (texgen faces shards)."""
import glob, io, json, math, os, sys, tarfile

import numpy as np
from skimage import color, draw, io as skio

out, count, check = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
img_dir = os.path.join(out, "img")


def samples(folder, limit=None):
    for path in sorted(glob.glob(f"{folder}/*/faces-*.tar")):
        with tarfile.open(path) as tar:
            group = {}
            for m in tar.getmembers():
                key, member = m.name.split(".", 1)
                group.setdefault(key, {})[member] = tar.extractfile(m).read()
            for key in sorted(group):
                g = group[key]
                g["meta"] = json.loads(g["json"])
                yield g
                limit = None if limit is None else limit - 1
                if limit == 0:
                    return


def png(g, member):
    a = skio.imread(io.BytesIO(g[member]))
    return np.stack([a] * 3, -1) if a.ndim == 2 else a[..., :3]


def with_landmarks(g):
    a = png(g, "makeup.png").copy()
    for (x, y), seen in zip(g["meta"]["landmarks"], g["meta"]["landmarks_visible"]):
        rr, cc = draw.disk((y, x), 2, shape=a.shape[:2])
        a[rr, cc] = (40, 255, 40) if seen else (255, 60, 60)
    return a


def save(name, a):
    skio.imsave(os.path.join(img_dir, name), a.astype(np.uint8), check_contrast=False)
    return f"img/{name}"


data = list(samples(f"{out}/faces"))
styles = ["none", "light", "natural", "heavy", "dramatic"]
yaw = lambda g: math.degrees(g["meta"]["coefficients"]["rotation"][1])
light = lambda g: g["meta"]["light"]["strength"]
# Contact sheet: a row per style; along it, samples ordered by yaw, alternately weak and strong light.
rows, picked = [], []
for s in styles:
    pool = sorted([g for g in data if g["meta"]["style"] == s], key=yaw)
    if not pool:
        continue
    idx = np.linspace(0, len(pool) - 1, min(6, len(pool))).round().astype(int)
    row = [png(pool[i], "makeup.png") for i in idx]
    row += [np.zeros_like(row[0])] * (6 - len(row))
    rows.append(np.concatenate(row, 1))
    picked.append(pool[idx[len(idx) // 2]])
sheet = save("faces_styles.png", np.concatenate(rows, 0))
# Members of a few samples: makeup | before | bare | skin | face | landmarks.
members = []
for g in picked[1:5]:
    members.append(np.concatenate([png(g, m) for m in ("makeup.png", "before.png", "bare.png", "skin.png", "face.png")]
                                  + [with_landmarks(g)], 1))
member_sheet = save("faces_members.png", np.concatenate(members, 0))

# Makeup strength: CIELAB ΔE (CIE76) between makeup.png and before.png, per style, over skin (foundation, blush,
# contour, concealer) and over the rest of the face (lips, eyes, brows).
def delta_e(g):
    a = color.rgb2lab(png(g, "makeup.png") / 255.0)
    b = color.rgb2lab(png(g, "before.png") / 255.0)
    e = np.linalg.norm(a - b, axis=-1)
    skin, face = png(g, "skin.png")[..., 0] > 127, png(g, "face.png")[..., 0] > 127
    rest = face & ~skin
    return e[skin].mean() if skin.any() else 0.0, e[rest].mean() if rest.any() else 0.0, np.percentile(e[face], 99) if face.any() else 0.0

table = []
for s in styles:
    vals = [delta_e(g) for g in data if g["meta"]["style"] == s]
    if vals:
        v = np.array(vals)
        table.append(f"<tr><td>{s}</td><td>{len(vals)}</td><td>{v[:, 0].mean():.1f}</td><td>{v[:, 1].mean():.1f}</td>"
                     f"<td>{v[:, 2].mean():.1f}</td></tr>")

splits = {}
for split in ("train", "val", "test"):
    m = json.load(open(f"{out}/faces/{split}/manifest.json"))
    splits[split] = (m["samples"], len(m["metadata"]["subjects"]))
report = json.load(open(f"{out}/faces/report.json"))

# Detector check: face-api on the pre-alignment render (384², the face ~180 px wide), per |yaw| bin.
det_rows = ""
det = list(samples(f"{out}/faces_detector")) if os.path.isdir(f"{out}/faces_detector") else []
if det:
    for lo, hi in ((0, 10), (10, 20), (20, 30.01)):
        bin_ = [g for g in det if lo <= abs(yaw(g)) < hi]
        found = [g for g in bin_ if g["meta"]["align"].get("detected")]
        errs = [g["meta"]["align"]["detector_landmark_error_px"] for g in found]
        det_rows += (f"<tr><td>{lo:.0f}–{min(hi, 30):.0f}°</td><td>{len(bin_)}</td><td>{len(found)}"
                     f" ({100 * len(found) / max(len(bin_), 1):.0f}%)</td>"
                     f"<td>{np.median(errs) if errs else float('nan'):.1f}</td></tr>")

print(f"""<h2>10. The face-image world (texgen faces)</h2>
<p>{count} samples at 256² ({report['samples_per_second']:.1f} samples/s on this machine, {report['seconds']:.0f} s):
train {splits['train'][0]} samples of {splits['train'][1]} subjects, val {splits['val'][0]} of {splits['val'][1]},
test {splits['test'][0]} of {splits['test'][1]} (splits by subject). Subjects are the 10 registered demo scans and 90
3DMM samples of the demo model; each sample draws a makeup style, SH light around Deep3DFaceRecon's ambient with a
dominant direction and colour, a Blinn-Phong key light on the roughness/specular maps, a pose (|yaw| ≤ 30°, |pitch| ≤
15°, |roll| ≤ 10°), a background (noise, gradient, or a photo python3-skimage ships), occluders in 30% of samples,
then is aligned by the 5-point alignment and rendered by the canonical camera (its coefficients reproduce bare.png).</p>
<figure><img src="{sheet}" style="max-width:100%"><figcaption>makeup.png by style (rows: none, light, natural, heavy,
dramatic), ordered by yaw along each row; light strength and colour vary per sample.</figcaption></figure>
<figure><img src="{member_sheet}" style="max-width:100%"><figcaption>Members of one sample per row: makeup.png (the
input), before.png (same light, no makeup), bare.png (albedo, no light), skin.png, face.png, and the 68 landmarks of the
json (green seen, red hidden by the head or an occluder).</figcaption></figure>
<table><tr><th>style</th><th>samples</th><th>ΔE on skin</th><th>ΔE lips/eyes/brows</th><th>ΔE p99 over the face</th></tr>
{''.join(table)}</table>
<p>Makeup strength: CIELAB ΔE (CIE76) between makeup.png and before.png of the same sample (same light, pose and
background), averaged over skin.png and over the rest of face.png; the per-region table of the makeup layers themselves
is in bench/BENCHMARKS.md (Makeup strength).</p>
""")
if det:
    print(f"""<table><tr><th>|yaw|</th><th>samples</th><th>face found</th><th>median landmark error (px at 256²)</th></tr>
{det_rows}</table>
<p>Detector check on {len(det)} samples aligned with <code>--align detector</code>: face-api's tiny face detector and
68-point net on the 384² pre-alignment render (the errors are against the projected landmark vertices, scaled to the
aligned frame). Faces it misses are aligned by their truth landmarks and say so in json.</p>""")
