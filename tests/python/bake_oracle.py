#!/usr/bin/python3
"""Independent oracle for `uvtools bake` (numpy + oiiotool, none of our code).

1. numpy: rasterises the layout's UV triangles at the input size (texel centres), decodes the maps (sRGB diffuse to
   linear, normals to vectors), box-filters over island texels only and compares with our outputs where an output
   texel has island texels under it (diffuse/roughness/specular: absolute difference; normals: angle).
2. oiiotool: `--resize:filter=box` (diffuse in linear light) agrees with ours wherever the whole footprint of an
   output texel lies inside an island.

usage: bake_oracle.py LAYOUT.obj INPUT_DIR OUTPUT_DIR SIZE [SIZE...]
       LAYOUT "-": a bake without a layout, where every texel counts (a plain box filter per map type).
"""
import os
import subprocess
import sys
import tempfile

import numpy as np
from skimage import io


def read(path):
    """Any of our map files as float in [0, 1] (oiiotool → float TIFF, read losslessly by tifffile)."""
    with tempfile.TemporaryDirectory() as d:
        subprocess.run(["oiiotool", path, "-d", "float", "--compression", "none", "-o", d + "/x.tif"], check=True)
        img = io.imread(d + "/x.tif").astype(np.float64)
    return img[..., None] if img.ndim == 2 else img


def is_srgb(path):
    info = subprocess.run(["oiiotool", "--info", "-v", path], capture_output=True, text=True).stdout
    return 'oiio:ColorSpace: "sRGB"' in info


def srgb_to_linear(x):
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def island_mask(obj, n):
    uv, faces = [], []
    for line in open(obj):
        t = line.split()
        if t[:1] == ["vt"]:
            uv.append([float(t[1]), float(t[2])])
        elif t[:1] == ["f"]:
            faces.append([int(c.split("/")[1]) - 1 for c in t[1:4]])
    uv, faces = np.array(uv), np.array(faces)
    p = np.stack([uv[:, 0] * n, (1 - uv[:, 1]) * n], 1)
    mask = np.zeros((n, n), bool)
    for f in faces:
        a, b, c = p[f]
        x0, x1 = int(max(0, np.floor(min(a[0], b[0], c[0])))), int(min(n - 1, np.ceil(max(a[0], b[0], c[0]))))
        y0, y1 = int(max(0, np.floor(min(a[1], b[1], c[1])))), int(min(n - 1, np.ceil(max(a[1], b[1], c[1]))))
        xs, ys = np.meshgrid(np.arange(x0, x1 + 1) + 0.5, np.arange(y0, y1 + 1) + 0.5)
        area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        if abs(area) < 1e-12:
            continue
        w = [((q[0] - xs) * (r[1] - ys) - (q[1] - ys) * (r[0] - xs)) / area for q, r in ((b, c), (c, a), (a, b))]
        mask[y0:y1 + 1, x0:x1 + 1] |= (w[0] >= -1e-9) & (w[1] >= -1e-9) & (w[2] >= -1e-9)
    return mask


def main(layout, src, dst, sizes):
    good = True
    maps = [m for m in ("diffuse", "normal", "roughness", "specular")
            for e in (".exr", ".tif", ".png") if os.path.exists(f"{src}/{m}{e}")]
    first = next(f"{src}/{maps[0]}{e}" for e in (".exr", ".tif", ".png") if os.path.exists(f"{src}/{maps[0]}{e}"))
    n = read(first).shape[0]
    mask = island_mask(layout, n) if layout != "-" else np.ones((n, n), bool)
    for m in maps:
        path = next(f"{src}/{m}{e}" for e in (".exr", ".tif", ".png") if os.path.exists(f"{src}/{m}{e}"))
        img = read(path)
        if m == "diffuse" and is_srgb(path):
            img = srgb_to_linear(img)
        if m == "normal":
            img = 2 * img - 1
        for s in sizes:
            f = n // s
            out_path = next(f"{dst}/{s}/{m}{e}" for e in (".exr", ".tif", ".png") if os.path.exists(f"{dst}/{s}/{m}{e}"))
            ours = read(out_path)
            if m == "diffuse" and is_srgb(out_path):
                ours = srgb_to_linear(ours)
            w = mask.reshape(s, f, s, f).sum((1, 3))
            ref = (img * mask[..., None]).reshape(s, f, s, f, -1).sum((1, 3)) / np.maximum(w, 1)[..., None]
            seen = w > 0
            if m == "normal":
                ref = ref[..., :3] / np.linalg.norm(ref[..., :3], axis=2, keepdims=True).clip(1e-12)
                got = 2 * ours[..., :3] - 1
                got /= np.linalg.norm(got, axis=2, keepdims=True).clip(1e-12)
                err = np.degrees(np.arccos(np.clip((ref * got).sum(2), -1, 1)))[seen].max()
                ok = err < 0.1
                detail = f"max angle {err:.3f} deg"
            else:
                err = np.abs(ref[..., :ours.shape[2]] - ours)[seen].max()
                ok = err < 2e-3
                detail = f"max |difference| {err:.2e}"
            good &= ok
            print(f"{'ok  ' if ok else 'FAIL'} {m} {s}: numpy island box filter, {seen.sum()} texels: {detail}")
            if m == "diffuse":
                # oiiotool, box filter in linear light, where the footprint is entirely inside an island.
                with tempfile.TemporaryDirectory() as d:
                    cmd = ["oiiotool", path]
                    if is_srgb(path):
                        cmd += ["--colorconvert", "sRGB", "linear"]
                    subprocess.run(cmd + ["--resize:filter=box", f"{s}x{s}", "-d", "float", "--compression", "none", "-o", d + "/o.tif"], check=True)
                    oiio = io.imread(d + "/o.tif").astype(np.float64)
                inside = w == f * f
                diff = np.abs(oiio[..., :ours.shape[2]] - ours)[inside]
                psnr = 10 * np.log10(1 / max((diff ** 2).mean(), 1e-20))
                ok = psnr > 50
                good &= ok
                print(f"{'ok  ' if ok else 'FAIL'} diffuse {s}: vs oiiotool --resize:filter=box inside islands "
                      f"({inside.sum()} texels): PSNR {psnr:.1f} dB, max {diff.max():.2e}")
    return 0 if good else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2], sys.argv[3], [int(s) for s in sys.argv[4:]]))
