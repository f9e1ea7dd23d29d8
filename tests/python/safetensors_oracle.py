#!/usr/bin/python3
"""Independent oracle for our safetensors files: parses them per the format specification with numpy only (no code of
ours), and checks a template file against its OBJ twin.

usage: safetensors_oracle.py TEMPLATE_DIR      (face.safetensors vs face.obj + landmarks.json)
       safetensors_oracle.py --write FILE      (writes a spec file with numpy for our reader to check)
"""
import json
import struct
import sys

import numpy as np

DTYPES = {"F32": np.float32, "F64": np.float64, "I32": np.int32, "I64": np.int64, "U8": np.uint8, "F16": np.float16}


def read_safetensors(path):
    with open(path, "rb") as f:
        raw = f.read()
    (n,) = struct.unpack("<Q", raw[:8])
    assert (8 + n) % 8 == 0, "data section not 8-byte aligned"
    header = json.loads(raw[8:8 + n].decode("utf-8"))
    data = raw[8 + n:]
    meta = header.pop("__metadata__", {})
    assert all(isinstance(v, str) for v in meta.values()), "metadata values must be strings"
    tensors, cursor = {}, 0
    for name, e in sorted(header.items(), key=lambda kv: kv[1]["data_offsets"][0]):
        b, end = e["data_offsets"]
        assert b == cursor, f"{name}: gap or overlap"
        dt = np.dtype(DTYPES[e["dtype"]]).newbyteorder("<")
        count = int(np.prod(e["shape"])) if e["shape"] else 1
        assert end - b == count * dt.itemsize, f"{name}: byte count"
        assert b % dt.itemsize == 0, f"{name}: misaligned"
        tensors[name] = np.frombuffer(data[b:end], dtype=dt).reshape(e["shape"])
        cursor = end
    assert cursor == len(data), "trailing bytes"
    return meta, tensors


def read_obj(path):
    v, vt, f, ft = [], [], [], []
    for line in open(path):
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            v.append([float(x) for x in p[1:4]])
        elif p[0] == "vt":
            vt.append([float(x) for x in p[1:3]])
        elif p[0] == "f":
            corners = [c.split("/") for c in p[1:]]
            f.append([int(c[0]) - 1 for c in corners])
            ft.append([int(c[1]) - 1 for c in corners])
    return np.array(v), np.array(vt), np.array(f), np.array(ft)


def check_template(folder):
    meta, t = read_safetensors(f"{folder}/face.safetensors")
    assert meta["units"] == "mm" and meta["format"] == "bareskin.template", meta
    V, VT, F, FT = read_obj(f"{folder}/face.obj")
    assert t["vertices"].shape == V.shape and t["triangles"].shape == F.shape
    assert np.abs(t["vertices"] - V).max() < 1e-3, "vertices differ"
    # Faces may start at another corner in the OBJ; compare as rotated triples.
    rot = [np.roll(t["triangles"], -k, axis=1) for k in range(3)]
    same = np.any([np.all(r == F, axis=1) for r in rot], axis=0)
    assert same.all(), f"{(~same).sum()} triangles differ"
    # UV per corner: the value at each corner must agree.
    uv_st = t["uvs"][t["uv_triangles"]]
    k = np.argmax([np.all(r == F, axis=1).sum() for r in rot])
    uv_obj = np.roll(VT[FT], k, axis=1)
    assert np.abs(uv_st - uv_obj).max() < 1e-5, "UVs differ"
    lm = json.load(open(f"{folder}/landmarks.json"))
    assert (t["landmark_vertices"] == np.array(lm["vertex_ids"])).all()
    assert np.abs(V[lm["vertex_ids"]] - np.array(lm["points"])).max() < 1e-3
    # UV layout health: signed areas of UV triangles (flipped = negative).
    a = uv_st[:, 1] - uv_st[:, 0]
    b = uv_st[:, 2] - uv_st[:, 0]
    area = 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    print(f"template ok: {len(V)} vertices, {len(F)} triangles, UV flipped {np.sum(area < 0)}, "
          f"degenerate {np.sum(np.abs(area) < 1e-12)}")


def write_reference(path):
    rng = np.random.default_rng(7)
    tensors = {"a_f32": rng.standard_normal((3, 4)).astype("<f4"), "b_f64": rng.standard_normal(5).astype("<f8"),
               "c_i32": np.arange(-3, 3, dtype="<i4").reshape(2, 3),
               "g_f32_3d": rng.standard_normal((2, 3, 4)).astype("<f4"), "d_u8": np.array([0, 7, 255], dtype=np.uint8),
               "e_f16": np.array([1.5, -2.25, 0.1], dtype="<f2"), "f_i64": np.array([2**40, -5], dtype="<i8")}
    order = sorted(tensors, key=lambda k: (-tensors[k].dtype.itemsize, k))
    header, blob = {"__metadata__": {"made_by": "numpy oracle"}}, b""
    for k in order:
        x = tensors[k]
        names = {np.float32: "F32", np.float64: "F64", np.int32: "I32", np.uint8: "U8", np.float16: "F16", np.int64: "I64"}
        header[k] = {"dtype": names[x.dtype.type], "shape": list(x.shape), "data_offsets": [len(blob), len(blob) + x.nbytes]}
        blob += x.tobytes()
    h = json.dumps(header).encode()
    h += b" " * ((8 - len(h) % 8) % 8)
    with open(path, "wb") as f:
        f.write(struct.pack("<Q", len(h)) + h + blob)
    stats = {k: {"min": float(v.astype(np.float64).min()), "max": float(v.astype(np.float64).max()),
                 "mean": float(v.astype(np.float64).mean()), "shape": list(v.shape),
                 "values": v.ravel().tolist()} for k, v in tensors.items()}
    print(json.dumps(stats))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--write":
        write_reference(sys.argv[2])
    elif len(sys.argv) == 2:
        check_template(sys.argv[1])
    else:
        sys.exit(__doc__)
