#!/usr/bin/python3
"""Independent oracle for mm-build / mm-eval (numpy only, none of our code): reads the model file and the registered
meshes and maps it was built from, and checks

- GPA: the stored transforms bring every mesh onto the stored mean, each optimally (its own Procrustes rotation to the
  mean is the identity) and the mean is the average of the aligned meshes;
- shape PCA against numpy's SVD of the centred data: standard deviations and subspace (principal angles);
- appearance mean against a numpy box filter of the sRGB-decoded diffuse maps;
- mm-eval's metrics.csv against explicit leave-one-out PCA (generalisation), the eigenvalues (compactness) and
  independent sampling (specificity, loosely).

- the C++ evaluator, through `mm-build --export-obj`: shape1_plus3sd.obj = mean + 3 sd_1 U_1.

usage: mm_oracle.py MODEL REGISTERED_DIR METRICS_CSV [EXPORT_DIR]
"""
import csv
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from bake_oracle import read  # noqa: E402  (lossless float through oiiotool)
from safetensors_oracle import read_safetensors  # noqa: E402


def obj_vertices(path):
    return np.array([[float(t) for t in line.split()[1:4]] for line in open(path) if line.startswith("v ")])


def ply_vertices(path):
    raw = open(path, "rb").read()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    header = raw[:end].decode().splitlines()
    assert "format binary_little_endian 1.0" in header, header[:3]
    n, props, in_vertex = 0, [], False
    for line in header:
        t = line.split()
        if t[:2] == ["element", "vertex"]:
            n, in_vertex = int(t[2]), True
        elif t[:1] == ["element"]:
            in_vertex = False
        elif t[:1] == ["property"] and in_vertex:
            props.append((t[2], {"float": "<f4", "double": "<f8"}[t[1]]))
    v = np.frombuffer(raw[end:], dtype=np.dtype(props), count=n)
    return np.stack([v["x"], v["y"], v["z"]], 1).astype(np.float64)


def mesh_vertices(d):
    return ply_vertices(d + "/mesh.ply") if os.path.exists(d + "/mesh.ply") else obj_vertices(d + "/mesh.obj")


def srgb_to_linear(x):
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def check(name, ok, detail):
    print(f"{'ok  ' if ok else 'FAIL'} {name}: {detail}")
    return ok


def main(model_path, registered, metrics_csv, export=None):
    meta, t = read_safetensors(model_path)
    subjects = json.loads(meta["subjects"])
    mean = t["shape_mean"].astype(np.float64)
    V = mean.shape[0]
    G = t["procrustes"].astype(np.float64)
    X = []
    for s, T in zip(subjects, G):
        P = mesh_vertices(f"{registered}/{s}")
        X.append(P @ T[:3, :3].T + T[:3, 3])
    X = np.array(X)  # n x V x 3, aligned
    n = len(X)
    good = True

    # GPA
    good &= check("GPA mean", np.abs(X.mean(0) - mean).max() < 1e-3, f"max |mean(aligned) - shape_mean| "
                  f"{np.abs(X.mean(0) - mean).max():.2e} mm")
    worst = 0
    for P in X:
        a, b = P - P.mean(0), mean - mean.mean(0)
        U, _, Wt = np.linalg.svd(a.T @ b)
        R = (U @ Wt).T
        worst = max(worst, np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))
    good &= check("GPA optimal", worst < 0.01, f"largest residual Procrustes rotation {worst:.2e} deg")

    # Shape PCA vs numpy SVD
    D = X.reshape(n, -1)
    Dc = D - D.mean(0)
    _, S, Wt = np.linalg.svd(Dc, full_matrices=False)
    k = t["shape_basis"].shape[0]
    sd = S[:k] / np.sqrt(n - 1)
    ours_sd = t["shape_stddev"].astype(np.float64)
    rel = np.abs(ours_sd - sd).max() / sd.max()
    good &= check("shape stddev", rel < 1e-4, f"max relative difference {rel:.2e} (stored float32)")
    B = t["shape_basis"].reshape(k, -1).astype(np.float64)
    gram = B @ B.T
    good &= check("shape basis orthonormal", np.abs(gram - np.eye(k)).max() < 1e-4,
                  f"max |B B^T - I| {np.abs(gram - np.eye(k)).max():.2e}")
    # Principal angles between the model's subspace and numpy's, over components with distinct variances.
    cos = np.linalg.svd(B @ Wt[:k].T, compute_uv=False)
    angle = np.degrees(np.arccos(np.clip(cos.min(), -1, 1)))
    good &= check("shape subspace", angle < 0.01, f"largest principal angle {angle:.2e} deg")

    # Appearance mean vs a numpy box filter in linear light
    if t["appearance_basis"].shape[0] > 0:
        R = t["appearance_mean"].shape[0]
        mask = t["appearance_mask"].astype(bool)
        acc = np.zeros((R, R, 3))
        with_maps = [s for s in subjects if os.path.exists(f"{registered}/{s}/diffuse.png")]  # others are left out
        for s in with_maps:
            img = srgb_to_linear(read(f"{registered}/{s}/diffuse.png")[..., :3])
            f = img.shape[0] // R
            acc += img.reshape(R, f, R, f, 3).mean((1, 3))
        acc /= len(with_maps)
        err = np.abs(acc[mask] - t["appearance_mean"][mask]).max()
        good &= check("appearance mean", err < 1e-4, f"max difference over {mask.sum()} texels {err:.2e}")

    if export:
        want = mean + 3 * t["shape_stddev"][0] * t["shape_basis"][0]
        err = np.abs(obj_vertices(export + "/shape1_plus3sd.obj") - want).max()
        good &= check("model evaluation", err < 1e-4, f"exported +3 sd shape vs numpy: max {err:.2e} mm")

    # Metrics
    rows = list(csv.DictReader(open(metrics_csv)))
    lam = S ** 2
    diff = max(abs(lam[:int(r["components"])].sum() / lam.sum() - float(r["compactness"])) for r in rows)
    good &= check("compactness", diff < 1e-5, f"max difference {diff:.2e} over {len(rows)} component counts")
    loo_err = 0
    for r in rows:
        K = int(r["components"])
        errs = []
        for i in range(n):
            rest = np.delete(D, i, 0)
            mu = rest.mean(0)
            _, _, Wr = np.linalg.svd(rest - mu, full_matrices=False)
            z = D[i] - mu
            res = z - Wr[:K].T @ (Wr[:K] @ z)
            errs.append(np.sqrt((res ** 2).sum() / V))
        loo_err = max(loo_err, abs(np.mean(errs) - float(r["generalization_mm"])))
    good &= check("generalisation", loo_err < 1e-3, f"max |ours - explicit leave-one-out PCA| {loo_err:.2e} mm")
    rng = np.random.default_rng(7)
    worst = 0
    for r in rows:
        K = int(r["components"])
        samples = (rng.standard_normal((2000, K)) * sd[:K]) @ Wt[:K] + D.mean(0)
        d2 = np.stack([((samples - D[j]) ** 2).sum(1) for j in range(n)], 1)
        d = np.sqrt(d2 / V).min(1).mean()
        worst = max(worst, abs(d - float(r["specificity_mm"])) / d)
    good &= check("specificity", worst < 0.05, f"max relative difference to 2000 numpy samples {worst:.3f}")
    return 0 if good else 1


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:5]))
