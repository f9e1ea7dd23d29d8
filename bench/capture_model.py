#!/usr/bin/env python3
"""A COLMAP TXT model of a synthetic capture, written from its true cameras (`landmarks scan --save-views DIR`:
DIR/cameras.json) and the scan's mesh, in an unknown frame: a similarity (scale, rotation, shift from --seed) applied
to everything, plus point noise. It stands in for COLMAP's output where COLMAP's SIFT finds too few features on smooth
synthetic skin, and tests the rest of the capture path (reading COLMAP's conventions, aligning its frame to the scan,
triangulating on the photos) against the truth.
Usage: capture_model.py CAMERAS.json MESH.obj OUT_DIR [--seed 1] [--points 3000] [--noise 0.2]"""
import argparse, json, os
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("cameras"); ap.add_argument("mesh"); ap.add_argument("out")
ap.add_argument("--seed", type=int, default=1); ap.add_argument("--points", type=int, default=3000)
ap.add_argument("--noise", type=float, default=0.2)
a = ap.parse_args()
rng = np.random.default_rng(a.seed)
cams = json.load(open(a.cameras))["cameras"]
V = np.array([[float(x) for x in l.split()[1:4]] for l in open(a.mesh) if l.startswith("v ")])
P = V[rng.choice(len(V), min(a.points, len(V)), replace=False)] + rng.normal(0, a.noise, (min(a.points, len(V)), 3))
# The unknown frame: x_model = s Q x + d.
q = rng.normal(size=4); q /= np.linalg.norm(q)
w, x, y, z = q
Q = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
              [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
              [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
s, d = 0.0137, rng.normal(0, 3, 3)
os.makedirs(a.out, exist_ok=True)
F = np.diag([1, -1, -1])  # ours (looks down -z, y up) -> COLMAP (looks down +z, y down)


def quat(R):
    t = np.trace(R)
    qw = np.sqrt(max(0, 1 + t)) / 2
    qx = np.copysign(np.sqrt(max(0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    qy = np.copysign(np.sqrt(max(0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    qz = np.copysign(np.sqrt(max(0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return qw, qx, qy, qz


with open(f"{a.out}/cameras.txt", "w") as f:
    c = cams[0]
    f.write("# synthetic\n1 SIMPLE_PINHOLE %d %d %.9g %.9g %.9g\n" % (c["width"], c["height"], c["focal"], c["cx"], c["cy"]))
with open(f"{a.out}/images.txt", "w") as f:
    for i, c in enumerate(cams, 1):
        R, t = np.array(c["R"]), np.array(c["t"])
        # p = R x + t, x = Q^T (x_m - d) / s  ->  p s = R Q^T x_m - R Q^T d + s t  (same pixels)
        Rm, tm = F @ R @ Q.T, F @ (s * t - R @ Q.T @ d)
        f.write("%d %.12g %.12g %.12g %.12g %.12g %.12g %.12g 1 %s\n\n" % ((i,) + quat(Rm) + tuple(tm) + (c["image"],)))
with open(f"{a.out}/points3D.txt", "w") as f:
    for i, p in enumerate(P, 1):
        m = s * Q @ p + d
        f.write("%d %.9g %.9g %.9g 128 128 128 0.5\n" % (i, *m))
print(f"{len(cams)} cameras, {len(P)} points in a frame scaled by {s}")
