"""Where the top 5% of `scan register`'s correspondence errors are (bench/BENCHMARKS.md, 2026-12-02 p95 diagnosis).
Usage: /usr/bin/python3 bench/register_errmap.py TEMPLATE_DIR REGISTERED_DIR SCANS_DIR
Per registered scan (REGISTERED_DIR/<id>/mesh.ply against SCANS_DIR/<id>/truth/correspondence.safetensors from
`scan synth`): the error split along the registered normal and tangential; the share of the top 5% by place on the
rest template (next to holes, rim distance, nose, eyes, mouth, brows, the rest) beside each place's share of the
area; and the cosine between the tangential error and the truth's own tangential displacement about the rest normal,
with both lengths (the registration slides a point along the truth's displacement when the cosine is near 1)."""
import glob, json, os, struct, sys
import numpy as np
from scipy.spatial import cKDTree

def safetensors(path):
    f = open(path, 'rb'); n = struct.unpack('<Q', f.read(8))[0]; head = json.loads(f.read(n)); data = f.read()
    out = {}
    for k, v in head.items():
        if k == '__metadata__': continue
        dt = {'F32': np.float32, 'I32': np.int32}[v['dtype']]
        a, b = v['data_offsets']; out[k] = np.frombuffer(data[a:b], dtype=dt).reshape(v['shape'])
    return out

def read_ply(path):
    f = open(path, 'rb'); header = b''
    while not header.endswith(b'end_header\n'): header += f.readline()
    h = header.decode(); nv = int(h.split('element vertex ')[1].split()[0]); nf = int(h.split('element face ')[1].split()[0])
    props = h.split('element vertex')[1].split('element face')[0].count('property float')
    V = np.frombuffer(f.read(4 * props * nv), dtype=np.float32).reshape(nv, props)
    F = np.zeros((nf, 3), np.int64)
    raw = f.read()
    rec = np.frombuffer(raw[:nf * 13], dtype=np.dtype([('n', 'u1'), ('i', '<i4', 3)]))
    F = rec['i'].astype(np.int64)
    return V[:, :3].astype(np.float64), V[:, 3:6].astype(np.float64), F

def read_obj(path):
    V, F = [], []
    for line in open(path):
        if line.startswith('v '): V.append([float(x) for x in line.split()[1:4]])
        elif line.startswith('f '): F.append([int(x.split('/')[0]) - 1 for x in line.split()[1:4]])
    return np.array(V), np.array(F)

def boundary_vertices(F):
    e = np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), axis=1)
    u, c = np.unique(e, axis=0, return_counts=True)
    return np.unique(u[c == 1])

def vertex_normals(V, F):
    """Area-weighted vertex normals (unit length)."""
    fn = np.cross(V[F[:, 1]] - V[F[:, 0]], V[F[:, 2]] - V[F[:, 0]])
    N = np.zeros_like(V)
    for k in range(3):
        np.add.at(N, F[:, k], fn)
    return N / np.linalg.norm(N, axis=1, keepdims=True)

def main():
    template, registered, scans = sys.argv[1], sys.argv[2], sys.argv[3]
    Vt, Ft = read_obj(os.path.join(template, 'face.obj'))
    Nt = vertex_normals(Vt, Ft)
    lm = np.array(json.load(open(os.path.join(template, 'landmarks.json')))['points'])
    lmv = cKDTree(Vt).query(lm)[1]
    rim = cKDTree(Vt[boundary_vertices(Ft)]).query(Vt)[0]
    near_lm = lambda ids, r: cKDTree(Vt[lmv[ids]]).query(Vt)[0] < r
    regions = [('rim <5 mm', rim < 5), ('rim 5-10 mm', (rim >= 5) & (rim < 10)),
               ('nose (27-35, 12 mm)', near_lm(list(range(27, 36)), 12)), ('eyes (36-47, 8 mm)', near_lm(list(range(36, 48)), 8)),
               ('mouth (48-67, 8 mm)', near_lm(list(range(48, 68)), 8)), ('brows (17-26, 8 mm)', near_lm(list(range(17, 27)), 8)),
               ('jaw line (0-16, 10 mm)', near_lm(list(range(0, 17)), 10))]
    for d in sorted(glob.glob(os.path.join(registered, 'subject_*'))):
        sid = os.path.basename(d)
        V, N, F = read_ply(os.path.join(d, 'mesh.ply'))
        t = safetensors(os.path.join(scans, sid, 'truth', 'correspondence.safetensors'))
        P, face = t['template_to_scan_point'].astype(np.float64), t['template_to_scan_face']
        valid = face >= 0
        e = V - P; err = np.linalg.norm(e, axis=1)
        nrm = np.abs(np.sum(e * N, axis=1)); tan = np.sqrt(np.maximum(err ** 2 - nrm ** 2, 0))
        hole = cKDTree(Vt[~valid]).query(Vt)[0] < 5 if (~valid).any() else np.zeros(len(Vt), bool)
        hole &= valid
        ev = err[valid]; p95 = np.quantile(ev, 0.95); top = valid & (err >= p95)
        row = {'p95': p95, 'median': np.median(ev), 'top normal share (|e.n|/|e|)': np.median(nrm[top] / err[top]),
               'top median tangential': np.median(tan[top]), 'top median normal': np.median(nrm[top])}
        assigned = np.zeros(len(Vt), bool)
        fr = {}
        for name, mask in [('next to a hole (5 mm)', hole)] + regions:
            m = mask & top & ~assigned; fr[name] = m.sum() / top.sum(); assigned |= m & True
        fr['rest'] = (top & ~assigned).sum() / top.sum()
        # share of each region in the valid vertices (for comparison: where the top 5% would be by chance)
        assigned2 = np.zeros(len(Vt), bool); base = {}
        for name, mask in [('next to a hole (5 mm)', hole)] + regions:
            m = mask & valid & ~assigned2; base[name] = m.sum() / valid.sum(); assigned2 |= m
        base['rest'] = (valid & ~assigned2).sum() / valid.sum()
        print(f"{sid}: median {row['median']:.3f} p95 {p95:.3f}; top 5%: median |e| {np.median(err[top]):.2f}, tangential {row['top median tangential']:.2f}, normal {row['top median normal']:.2f} mm")
        print('   ' + ', '.join(f"{k} {100*fr[k]:.0f}% (area {100*base[k]:.0f}%)" for k in fr))
        T = P - Vt  # the truth's displacement (scan synth without a pose: scan frame = template frame)
        tan = lambda X: X - np.sum(X * Nt, 1, keepdims=True) * Nt
        et, tt = tan(e)[top], tan(T)[top]
        cos = np.sum(et * tt, 1) / np.maximum(np.linalg.norm(et, axis=1) * np.linalg.norm(tt, axis=1), 1e-12)
        print(f"   top 5%: cos(tangential error, truth's tangential displacement) {np.median(cos):+.2f}; "
              f"truth's tangential {np.median(np.linalg.norm(tt, axis=1)):.2f} mm, registered "
              f"{np.median(np.linalg.norm(tan(V - Vt)[top], axis=1)):.2f} mm")


if __name__ == '__main__':
    main()
