"""How far a prior "the scan differs from the placed template along the normals" can take a registration
(bench/BENCHMARKS.md, "the tangential prior's reference"). Per `scan synth` scan: the part of the truth's displacement
that lies along the surface (tangential to the template's normals, rotated with the frame), median / p95 over the
template vertices with a true point, from three placements of the rest template:
  rest        the template as the generator displaced it (scan synth's own similarity applied);
  landmarks   the Umeyama similarity from the template's landmark vertices to the scan's landmarks.json;
  fitted      the similarity under which the registration's vertices are best explained as displacements along the
              normals (what `scan register`'s tangential prior refits at every iteration, here on 6,000 vertices);
and the registration's own correspondence error. A strict normal prior from a placement cannot beat its column.
Usage: /usr/bin/python3 bench/register_frame_check.py TEMPLATE_DIR REGISTERED_DIR SCANS_DIR"""
import glob, json, os, sys
import numpy as np
from scipy.optimize import least_squares
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from register_errmap import read_obj, read_ply, safetensors, vertex_normals  # noqa: E402


def umeyama(X, Y):
    mx, my = X.mean(0), Y.mean(0)
    U, D, Vh = np.linalg.svd((Y - my).T @ (X - mx) / len(X))
    E = np.eye(3)
    if np.linalg.det(U) * np.linalg.det(Vh) < 0:
        E[2, 2] = -1
    R = U @ E @ Vh
    s = np.trace(np.diag(D) @ E) / ((X - mx) ** 2).sum(1).mean()
    return s, R, my - s * R @ mx


def fitted_frame(V, N, X):
    def residual(p):
        R, s, t = Rotation.from_rotvec(p[:3]).as_matrix(), np.exp(p[3]), p[4:]
        d, n = X - (s * V @ R.T + t), N @ R.T
        return (d - np.sum(d * n, 1, keepdims=True) * n).ravel()
    p = least_squares(residual, np.zeros(7)).x
    return np.exp(p[3]), Rotation.from_rotvec(p[:3]).as_matrix(), p[4:]


def tangential(D, N, valid):
    t = np.linalg.norm(D - np.sum(D * N, 1, keepdims=True) * N, axis=1)[valid]
    return f"{np.median(t):.2f} / {np.quantile(t, 0.95):.2f}"


def main():
    template, registered, scans = sys.argv[1:4]
    Vt, Ft = read_obj(os.path.join(template, 'face.obj'))
    Nt = vertex_normals(Vt, Ft)
    lmv = cKDTree(Vt).query(np.array(json.load(open(os.path.join(template, 'landmarks.json')))['points']))[1]
    rng = np.random.default_rng(0)
    print("scan: truth's tangential displacement median / p95 (mm) from rest | landmarks | fitted; registration error")
    for d in sorted(glob.glob(os.path.join(registered, 'subject_*'))):
        sid = os.path.basename(d)
        t = safetensors(os.path.join(scans, sid, 'truth', 'correspondence.safetensors'))
        P, valid = t['template_to_scan_point'].astype(np.float64), t['template_to_scan_face'] >= 0
        sim = json.load(open(os.path.join(scans, sid, 'truth', 'identity.json')))['similarity']
        X = read_ply(os.path.join(d, 'mesh.ply'))[0]
        L = np.array(json.load(open(os.path.join(scans, sid, 'landmarks.json')))['points'])
        pick = rng.choice(np.where(valid)[0], min(6000, int(valid.sum())), replace=False)
        frames = {'rest': (sim['scale'], np.array(sim['rotation']), np.array(sim['translation'])),
                  'landmarks': umeyama(Vt[lmv], L),
                  'fitted': fitted_frame(Vt[pick], Nt[pick], X[pick])}
        cols = [tangential(P - (s * Vt @ R.T + tr), Nt @ R.T, valid) for s, R, tr in frames.values()]
        e = np.linalg.norm(X - P, axis=1)[valid]
        print(f"{sid}: {' | '.join(cols)}; registration {np.median(e):.2f} / {np.quantile(e, 0.95):.2f}")


if __name__ == '__main__':
    main()
