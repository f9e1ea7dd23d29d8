#!/usr/bin/env python3
"""How far can any G get against the bare truth? Oracles on a `texgen faces` world, no network involved.

G's target in the CPU profile is the bare albedo: the input photo with its makeup AND its light taken off. One photo
cannot tell a bright face under a dim light from a dim face under a bright light (the world draws the ambient light
×0.75–1.15 and a warm/cool tint independently of the subject), so even a G that recovered every detail would still
have to guess the face's overall level and colour. This script measures that ceiling on the held-out split:

  input            the photo unchanged (the do-nothing baseline every eval.json reports)
  global gain      the photo × one per-channel gain per image, predicted from the photo (no detail fixed)
  no makeup, gain  the makeup-free photo ("before") × that gain: makeup removed perfectly, the light's shading kept
  ceiling          the bare truth itself with its level and colour set by the predictor: every detail right, the
                   global level only as good as a predictor that sees the photo can make it

The predictor is a ridge regression from statistics of the photo's face pixels (per-channel mean, spread and
quantiles of the log colour) to the log of the truth's per-channel mean, fitted on the train split. A network can
use more cues than these statistics, so "ceiling" is an estimate, not a proof; the gap between it and "input" is the
room G has. PSNRs are over the face mask's whole pixels at the profile's working size (area-resized), as `train
bareskin`'s psnr_face_* metrics are, averaged per image; the interval is 95% over held-out subjects.

  /usr/bin/python3 bench/bareskin_ceiling.py <faces/> [--size 64] [--train 1500] [--json out.json]
                                            [--level-oracle <faces split/> <out/>]

--level-oracle writes the ceiling's images for another split (e.g. bench/bareskinnet_stability.sh's subjects): each
sample's bare truth at full size with the level the predictor (fitted on <faces/>'s train split) reads from its
makeup photo, as <out>/<subject>/<key>.png, the layout bareskinnet_stability.sh unwraps.
"""
import argparse
import io
import json
import os
import sys

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from face_shards import member, split_samples, whole_footprint  # noqa: E402


def samples(faces, split, size, limit):
    """(makeup, before, bare, face mask, subject, style) per sample of a split, area-resized to size²."""
    out = []
    for key, t, meta in split_samples(faces, split, "bareskin_ceiling"):
        get = lambda name: member(t, key, name, size)
        face = whole_footprint(get("face"))
        out.append((get("makeup"), get("before"), get("bare"), face, meta["subject"], meta["style"]))
        if len(out) >= limit:
            break
    return out


def features(photo, mask):
    x = np.log(photo[mask] + 1e-3)
    q = np.quantile(x, [0.1, 0.5, 0.9], axis=0).ravel()
    return np.concatenate([x.mean(0), x.std(0), q, [1.0]])


def level(img, mask):
    return np.log(img[mask].mean(0) + 1e-3)


def psnr(a, b, mask):
    return -10 * np.log10(((np.clip(a, 0, 1) - b)[mask] ** 2).mean())


def interval(values, subjects):
    per = {}
    for v, s in zip(values, subjects):
        per.setdefault(s, []).append(v)
    m = np.array([np.mean(v) for v in per.values()])
    return float(np.mean(values)), float(1.96 * m.std(ddof=1) / np.sqrt(len(m))) if len(m) > 1 else float("nan")


def write_level_oracle(W, split_dir, dst, size):
    """The ceiling's image of every sample of split_dir: the full-size bare truth at the predicted level."""
    faces, split = os.path.split(os.path.normpath(split_dir))
    n = 0
    for key, t, meta in split_samples(faces, split, "bareskin_ceiling"):
        mask = whole_footprint(member(t, key, "face", size))
        predicted = features(member(t, key, "makeup", size), mask) @ W
        gain = np.exp(predicted - level(member(t, key, "bare", size), mask))
        bare = np.asarray(Image.open(io.BytesIO(t.extractfile(f"{key}.bare.png").read())), np.float64) / 255
        d = os.path.join(dst, meta["subject"].replace("/", "_"))
        os.makedirs(d, exist_ok=True)
        Image.fromarray(np.round(np.clip(bare * gain, 0, 1) * 255).astype(np.uint8)).save(os.path.join(d, key + ".png"))
        n += 1
    print(f"wrote {n} level-oracle images to {dst}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("faces")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--train", type=int, default=1500, help="train samples for the level predictor")
    ap.add_argument("--json")
    ap.add_argument("--level-oracle", nargs=2, metavar=("SPLIT", "OUT"),
                    help="write the ceiling's images of another split (bareskinnet_stability.sh's layout) and stop")
    a = ap.parse_args()
    train = samples(a.faces, "train", a.size, a.train)
    X = np.array([features(s[0], s[3]) for s in train])
    Y = np.array([level(s[2], s[3]) for s in train])
    W = np.linalg.solve(X.T @ X + 1e-3 * np.eye(X.shape[1]), X.T @ Y)
    if a.level_oracle:
        write_level_oracle(W, *a.level_oracle, a.size)
        return
    test = samples(a.faces, "test", a.size, 10**9)
    rows = {"input": [], "global gain": [], "no makeup, gain": [], "ceiling": []}
    for photo, before, bare, mask, _, _ in test:
        predicted = features(photo, mask) @ W
        rows["input"].append(psnr(photo, bare, mask))
        rows["global gain"].append(psnr(photo * np.exp(predicted - level(photo, mask)), bare, mask))
        rows["no makeup, gain"].append(psnr(before * np.exp(predicted - level(before, mask)), bare, mask))
        rows["ceiling"].append(psnr(bare * np.exp(predicted - level(bare, mask)), bare, mask))
    subjects = [s[4] for s in test]
    result = {"faces": a.faces, "size": a.size, "test_samples": len(test), "test_subjects": len(set(subjects)),
              "train_samples": len(train), "psnr_face_bare": {}}
    print(f"held-out split of {a.faces}: {len(test)} samples, {len(set(subjects))} subjects, {a.size}²")
    print("| oracle | PSNR on the face vs the bare truth (dB) |\n|---|---|")
    for name, values in rows.items():
        m, ci = interval(values, subjects)
        result["psnr_face_bare"][name] = {"mean": m, "ci95": ci}
        print(f"| {name} | {m:.2f} ± {ci:.2f} |")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(result, f, indent=1)


if __name__ == "__main__":
    main()
