#!/usr/bin/env python3
"""Fixtures of tests/cli/texture.sh, written independently of the C++ writers:
  texture_cli_fixture.py model PATH SEED        a tiny morphable model file (a planar 9x9 grid 'face'; the
                                                 safetensors layout of docs/file_formats.md), different per seed
  texture_cli_fixture.py shards DIR N [DROP]    a texture shard set of N procedural samples (32² maps, 128² diffuse_hr and normal_hr)
                                                 with manifest.json; DROP names a member to leave out"""
import io
import json
import os
import struct
import sys
import tarfile

import numpy as np
from PIL import Image

from spec_writers import safetensors


def model(path, seed):
    rng = np.random.default_rng(int(seed))
    n = 9
    u, v = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    V = np.stack([(u - 0.5) * 150, (v - 0.5) * 200, 50 * np.exp(-((u - .5) ** 2 + (v - .5) ** 2) * 4)], -1)
    V = V.reshape(-1, 3).astype(np.float32)
    tris = []
    for r in range(n - 1):
        for c in range(n - 1):
            a, b, d, e = r * n + c, r * n + c + 1, (r + 1) * n + c, (r + 1) * n + c + 1
            tris += [[a, b, e], [a, e, d]]
    F = np.array(tris, np.int32)
    uv = np.stack([u.ravel(), v.ravel()], -1).astype(np.float32)
    R = 16
    basis = lambda *shape: rng.normal(size=shape).astype(np.float32)
    tensors = {
        "shape_mean": ("F32", V), "shape_basis": ("F32", basis(2, len(V), 3) * 0.01),
        "shape_stddev": ("F32", np.ones(2, np.float32)),
        "expression_basis": ("F32", basis(1, len(V), 3) * 0.01), "expression_stddev": ("F32", np.ones(1, np.float32)),
        "appearance_mean": ("F32", np.full((R, R, 3), 0.5, np.float32)),
        "appearance_basis": ("F32", basis(1, R, R, 3) * 0.01), "appearance_stddev": ("F32", np.ones(1, np.float32)),
        "appearance_mask": ("U8", np.ones((R, R), np.uint8)),
        "triangles": ("I32", F), "uvs": ("F32", uv), "uv_triangles": ("I32", F),
        "landmark_vertices": ("I32", (np.arange(68) % len(V)).astype(np.int32)),
        "vertex_region": ("U8", np.zeros(len(V), np.uint8)), "procrustes": ("F32", np.zeros((0, 4, 4), np.float32)),
    }
    safetensors(path, tensors, {"format": "bareskin.morphable_model", "format_version": "1", "seed": str(seed)})


def png(array, bits=8):
    array = np.clip(array, 0, 1)
    buf = io.BytesIO()
    if bits == 16:
        Image.fromarray((array * 65535 + 0.5).astype(np.uint16)[..., 0]).save(buf, "PNG")  # grey 16-bit
    else:
        img = (array * 255 + 0.5).astype(np.uint8)
        Image.fromarray(img[..., 0] if img.shape[-1] == 1 else img).save(buf, "PNG")
    return buf.getvalue()


def shards(folder, count, drop=""):
    os.makedirs(folder, exist_ok=True)
    rng = np.random.default_rng(0)
    name = "texture-000000.tar"
    with tarfile.open(os.path.join(folder, name), "w") as tar:
        for i in range(int(count)):
            key = f"{i:08d}"
            field = lambda s, c: rng.uniform(0.2, 0.8, (s, s, c)).astype(np.float32)
            members = {"unwrap.png": png(field(32, 3)), "confidence.png": png(field(32, 1)),
                       "mm_albedo.png": png(field(32, 3)), "mm_normal.png": png(field(32, 3)),
                       "mm_position.png": png(field(32, 3)), "diffuse.png": png(field(32, 3)),
                       "normal.png": png(field(32, 3)), "roughness.png": png(field(32, 1)),
                       "specular.png": png(field(32, 1)), "diffuse_hr.png": png(field(128, 3)),
                       "normal_hr.png": png(field(128, 3)),
                       "json": json.dumps({"subject": f"mm/{i:06d}"}).encode()}
            for member, data in members.items():
                if member.split(".")[0] == drop:
                    continue
                info = tarfile.TarInfo(f"{key}.{member}")
                info.size = len(data)
                tar.addfile(info, io.BytesIO(data))
    path = os.path.join(folder, name)
    import zlib
    crc = zlib.crc32(open(path, "rb").read()) & 0xFFFFFFFF
    json.dump({"format": "bareskin-shards/1", "samples": int(count),
               "shards": [{"name": name, "samples": int(count), "crc32": crc, "bytes": os.path.getsize(path)}],
               "metadata": {"kind": "texture", "split": "train"}}, open(os.path.join(folder, "manifest.json"), "w"))


if __name__ == "__main__":
    {"model": model, "shards": shards}[sys.argv[1]](*sys.argv[2:])
