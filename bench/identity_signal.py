#!/usr/bin/env python3
"""How much a face's identity shows in an aligned photo: the 3DMM's identity α ~ N(0, 1) (truncated at ±2, as texgen
faces draws it) against the mean face, as the mean per-vertex distance (mm, what `recon --eval` calls the mean face's
shape error) and as the mean image displacement of landmarks 17-67 through the canonical camera (focal 1015 px at 224²,
1000 mm away; the lateral part, px) at the sizes given. F can learn identity only as far as it resolves these pixels.

    python3 bench/identity_signal.py <model.safetensors> [sizes=128,224,256]
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "python"))
from safetensors_oracle import read_safetensors  # noqa: E402


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    sizes = [int(s) for s in (sys.argv[2] if len(sys.argv) > 2 else "128,224,256").split(",")]
    _, t = read_safetensors(sys.argv[1])
    basis, stddev = t["shape_basis"].astype(np.float64), t["shape_stddev"].astype(np.float64)
    landmarks = t["landmark_vertices"].astype(int)[17:]
    alpha = np.clip(np.random.default_rng(0).standard_normal((2000, len(stddev))), -2, 2)
    offset = np.einsum("nk,kvc->nvc", alpha * stddev, basis)  # [draws, V, 3] mm from the mean face
    per_vertex = np.median(np.linalg.norm(offset, axis=2).mean(1))
    lateral = np.median(np.linalg.norm(offset[:, landmarks, :2], axis=2).mean(1))
    print(f"{len(stddev)} identity components; 2000 draws, medians over faces")
    print(f"mean face's shape error (mean per vertex): {per_vertex:.2f} mm")
    for s in sizes:
        print(f"landmarks 17-67 moved by identity at {s}²: {lateral * 1015 * s / 224 / 1000:.2f} px")


if __name__ == "__main__":
    main()
