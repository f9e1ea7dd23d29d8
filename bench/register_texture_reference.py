#!/usr/bin/python3
"""The reference for `scan register --texture-refine`: the mean, in linear light, of diffuse maps already in the
template UV (e.g. a first pass's registered/<id>/diffuse.png of other scans), written as an sRGB PNG.
Usage: bench/register_texture_reference.py OUT.png DIFFUSE.png [DIFFUSE.png ...]
Texels that are black in a map (outside its transfer) do not count towards that texel's mean."""
import sys

import numpy as np
from PIL import Image


def to_linear(c):
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def to_srgb(c):
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(np.maximum(c, 0), 1 / 2.4) - 0.055)


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    total = count = None
    for path in sys.argv[2:]:
        rgb = to_linear(np.asarray(Image.open(path).convert("RGB"), dtype=np.float64) / 255)
        if total is None:
            total, count = np.zeros_like(rgb), np.zeros(rgb.shape[:2])
        if rgb.shape != total.shape:
            sys.exit(f"{path}: {rgb.shape[1]}x{rgb.shape[0]}, the first map is {total.shape[1]}x{total.shape[0]}: give maps of one size")
        filled = rgb.sum(axis=2) > 1e-4
        total[filled] += rgb[filled]
        count += filled
    mean = total / np.maximum(count, 1)[..., None]
    Image.fromarray(np.round(255 * np.clip(to_srgb(mean), 0, 1)).astype(np.uint8)).save(sys.argv[1])
    print(f"{sys.argv[1]}: mean of {len(sys.argv) - 2} maps")


main()
