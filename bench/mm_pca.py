"""numpy side of bench/mm_pca.sh: times np.linalg.svd(X - mean, full_matrices=False) on the same data (float64, median
of 3) and compares with our PCA: principal angles between the subspaces and the variances.
usage: mm_pca.py OUT_DIR OUR_SECONDS"""
import json
import struct
import sys
import time

import numpy as np


def read(path):
    raw = open(path, "rb").read()
    n = struct.unpack("<Q", raw[:8])[0]
    h = json.loads(raw[8:8 + n])
    h.pop("__metadata__", None)
    out = {}
    for name, e in h.items():
        b, end = e["data_offsets"]
        out[name] = np.frombuffer(raw[8 + n + b:8 + n + end], dtype={"F32": "<f4", "F64": "<f8"}[e["dtype"]]).reshape(e["shape"])
    return out


d, ours_s = sys.argv[1], float(sys.argv[2])
X = read(d + "/data.safetensors")["X"].astype(np.float64)
ours = read(d + "/ours.safetensors")
k = ours["basis"].shape[0]
times = []
for _ in range(3):
    t0 = time.perf_counter()
    Xc = X - X.mean(0)
    _, S, Wt = np.linalg.svd(Xc, full_matrices=False)
    times.append(time.perf_counter() - t0)
numpy_s = sorted(times)[1]
variance = S[:k] ** 2 / (X.shape[0] - 1)
rel = np.abs(ours["variance"] - variance) / variance
cos = np.linalg.svd(ours["basis"] @ Wt[:k].T, compute_uv=False)
angle = np.arccos(np.clip(cos.min(), -1, 1))
# The last kept component against the next is the least separated; report its gap too.
gap = (variance[-1] - S[k] ** 2 / (X.shape[0] - 1)) / variance[0] if k < len(S) else float("nan")
print(f"numpy svd {numpy_s:.3f} s (median of 3) | ours {ours_s:.3f} s | ratio ours/numpy {ours_s / numpy_s:.3f}")
print(f"largest principal angle {angle:.2e} rad; variances: max relative difference {rel.max():.2e} "
      f"(smallest kept / largest variance {variance[-1] / variance[0]:.1e}, gap to the next {gap:.1e})")
