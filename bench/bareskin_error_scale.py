#!/usr/bin/env python3
"""Where G's error against the bare truth lies: in the face's level and tint, in smooth regions, or in fine detail.

Reads `bareskin demakeup --aligned` outputs (<G out>/<key>/bare.png) of a `texgen faces` split's makeup photos and
scores them on the face region (face.png) at the profile's working size, averaged per image:

  input      the makeup photo unchanged
  G          G's bare-skin image
  + level    G's image times one gain per channel, fitted to the truth by least squares: G with a perfect level
  + smooth   G's image with its error coarser than a (2r+1)² box removed (the box mean of the error over the face
             region subtracted): what is left is G's error in fine detail

The gap G → + level is what the light's ambiguity and G's colour costs; + level → + smooth is the error in smooth
regions (shading, traces of blush and lipstick); what + smooth leaves is fine detail.

  bareskin demakeup <split>/makeup photos --aligned --run <G run> -o <G out>     (one PNG per sample key)
  /usr/bin/python3 bench/bareskin_error_scale.py <faces/> <split> <G out> [--size 128] [--radius 4]
"""
import argparse
import glob
import os
import sys

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from face_shards import member, png, split_samples, whole_footprint  # noqa: E402


def box_mean(a, r):
    p = np.pad(a, ((r, r), (r, r), (0, 0)), mode="edge")
    return sliding_window_view(p, (2 * r + 1, 2 * r + 1), axis=(0, 1)).mean((-1, -2))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("faces")
    ap.add_argument("split")
    ap.add_argument("g_out")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--radius", type=int, default=4)
    a = ap.parse_args()
    rows = []
    for key, t, _ in split_samples(a.faces, a.split, "bareskin_error_scale"):
        out = os.path.join(a.g_out, key, "bare.png")
        if not os.path.exists(out):
            continue
        truth = member(t, key, "bare", a.size)[..., :3]
        photo = member(t, key, "makeup", a.size)[..., :3]
        face = member(t, key, "face", a.size)
        mask = whole_footprint(face if face.ndim == 2 else face[..., 0])
        g = png(open(out, "rb").read(), a.size)[..., :3]

        def psnr(img):
            return -10 * np.log10(((img - truth)[mask] ** 2).mean())

        gain = (g[mask] * truth[mask]).sum(0) / (g[mask] ** 2).sum(0)
        m = mask[..., None].astype(np.float64)
        smooth = box_mean((g - truth) * m, a.radius) / np.maximum(box_mean(m, a.radius), 1e-6)
        rows.append((psnr(photo), psnr(g), psnr(g * gain), psnr(g - smooth * m)))
    if not rows:
        sys.exit(f"bareskin_error_scale: no <key>/bare.png in {a.g_out} for the samples of {a.faces}/{a.split}")
    r = np.array(rows)
    print(f"{len(r)} faces of {a.faces}/{a.split} at {a.size}², PSNR on the face region (dB, mean over images):")
    for name, col in zip(["input", "G", "+ level", f"+ smooth ({2 * a.radius + 1}² box)"], r.T):
        print(f"  {name:24s} {col.mean():6.2f}")


if __name__ == "__main__":
    main()
