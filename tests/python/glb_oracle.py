#!/usr/bin/env python3
"""Independent reader of a glTF 2.0 binary (.glb): parses the chunks with struct + json, checks the structure the
glTF 2.0 specification requires of what bareskin writes (header, chunk order and padding, buffer views inside the
buffer, accessors inside their views, POSITION bounds, index range, unit normals, PNG images, the PBR material and
KHR_materials_specular), and prints a JSON summary. Exits 1 with the reason on the first violation.
Usage: glb_oracle.py avatar.glb"""
import json
import struct
import sys
import zlib

import numpy as np

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
DTYPES = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}


def fail(message):
    print("glb_oracle: " + message, file=sys.stderr)
    sys.exit(1)


def decode_png(png):
    """8-bit, non-interlaced PNG → [H, W, C] uint8, by zlib and the five row filters of the PNG specification."""
    if png[:8] != b"\x89PNG\r\n\x1a\n":
        fail("texture is not a PNG")
    pos, idat, header = 8, b"", None
    while pos < len(png):
        length, kind = struct.unpack_from(">I4s", png, pos)
        body = png[pos + 8: pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, color, _, _, interlace = header
    channels = {0: 1, 4: 2, 2: 3, 6: 4}.get(color)
    if depth != 8 or interlace or channels is None:
        fail(f"texture PNG depth {depth} colour type {color} interlace {interlace} not read here")
    raw = np.frombuffer(zlib.decompress(idat), np.uint8).reshape(height, 1 + width * channels)
    out = np.zeros((height, width * channels), np.int32)
    prev = np.zeros(width * channels, np.int32)
    for y in range(height):
        kind, row = raw[y, 0], raw[y, 1:].astype(np.int32)
        cur = np.zeros_like(row)
        if kind in (0, 2):  # None, Up: no dependence along the row
            out[y] = prev = (row + (prev if kind == 2 else 0)) & 255
            continue
        if kind == 1:  # Sub: a running sum per channel
            out[y] = prev = (np.cumsum(row.reshape(width, channels), axis=0) & 255).ravel()
            continue
        for x in range(len(row)):
            a = cur[x - channels] if x >= channels else 0
            b = prev[x]
            c = prev[x - channels] if x >= channels else 0
            if kind == 0:
                pred = 0
            elif kind == 1:
                pred = a
            elif kind == 2:
                pred = b
            elif kind == 3:
                pred = (a + b) // 2
            else:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (row[x] + pred) & 255
        out[y], prev = cur, cur
    return out.reshape(height, width, channels).astype(np.uint8)


def as_rgba(pixels):
    """How a glTF reader samples an image: grey → R = G = B, alpha 1 where the PNG has none."""
    c = pixels.shape[2]
    rgb = np.repeat(pixels[..., :1], 3, axis=2) if c <= 2 else pixels[..., :3]
    alpha = pixels[..., c - 1:] if c in (2, 4) else np.full(pixels.shape[:2] + (1,), 255, np.uint8)
    return np.concatenate([rgb, alpha], axis=2) / 255.0


def main(path):
    data = open(path, "rb").read()
    if len(data) < 20:
        fail("file too short")
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != 0x46546C67 or version != 2:
        fail("bad header")
    if length != len(data):
        fail(f"header length {length} != file size {len(data)}")
    json_len, json_type = struct.unpack_from("<II", data, 12)
    if json_type != 0x4E4F534A or json_len % 4:
        fail("first chunk is not a 4-byte aligned JSON chunk")
    gltf = json.loads(data[20:20 + json_len].decode("utf-8"))
    offset = 20 + json_len
    bin_len, bin_type = struct.unpack_from("<II", data, offset)
    if bin_type != 0x004E4942 or bin_len % 4:
        fail("second chunk is not a 4-byte aligned BIN chunk")
    binary = data[offset + 8: offset + 8 + bin_len]
    if offset + 8 + bin_len != len(data):
        fail("trailing bytes after the BIN chunk")
    if gltf["asset"]["version"] != "2.0":
        fail("asset.version is not 2.0")
    if gltf["buffers"][0]["byteLength"] > bin_len:
        fail("buffer longer than the BIN chunk")

    views = gltf["bufferViews"]
    for i, v in enumerate(views):
        if v["buffer"] != 0 or v.get("byteOffset", 0) + v["byteLength"] > gltf["buffers"][0]["byteLength"]:
            fail(f"bufferView {i} outside the buffer")

    def read(index):
        a = gltf["accessors"][index]
        v = views[a["bufferView"]]
        dtype = DTYPES[a["componentType"]]
        n = COMPONENTS[a["type"]]
        start = v.get("byteOffset", 0) + a.get("byteOffset", 0)
        size = a["count"] * n * np.dtype(dtype).itemsize
        if start % np.dtype(dtype).itemsize:
            fail(f"accessor {index} misaligned")
        if a.get("byteOffset", 0) + size > v["byteLength"]:
            fail(f"accessor {index} outside its bufferView")
        return np.frombuffer(binary, dtype=dtype, count=a["count"] * n, offset=start).reshape(a["count"], n)

    prim = gltf["meshes"][gltf["nodes"][0]["mesh"]]["primitives"][0]
    attr = prim["attributes"]
    pos = read(attr["POSITION"])
    a = gltf["accessors"][attr["POSITION"]]
    if not (np.allclose(pos.min(0), a["min"]) and np.allclose(pos.max(0), a["max"])):
        fail("POSITION min/max do not match the data")
    nrm = read(attr["NORMAL"])
    tan = read(attr["TANGENT"])
    uv = read(attr["TEXCOORD_0"])
    idx = read(prim["indices"]).ravel()
    count = len(pos)
    for name, arr in (("NORMAL", nrm), ("TANGENT", tan), ("TEXCOORD_0", uv)):
        if len(arr) != count:
            fail(f"{name} count {len(arr)} != POSITION count {count}")
    if idx.size % 3 or idx.max() >= count:
        fail("indices out of range or not triangles")
    if not np.allclose(np.linalg.norm(nrm, axis=1), 1, atol=1e-3):
        fail("NORMAL not unit length")
    if not np.allclose(np.linalg.norm(tan[:, :3], axis=1), 1, atol=1e-3) or not np.all(np.abs(tan[:, 3]) == 1):
        fail("TANGENT not unit xyz with w = +-1")

    pixels = []
    for i, image in enumerate(gltf["images"]):
        v = views[image["bufferView"]]
        png = binary[v.get("byteOffset", 0): v.get("byteOffset", 0) + v["byteLength"]]
        if image["mimeType"] != "image/png" or png[:8] != b"\x89PNG\r\n\x1a\n":
            fail(f"image {i} is not a PNG")
        pixels.append(as_rgba(decode_png(png)))
    mat = gltf["materials"][prim["material"]]
    pbr = mat["pbrMetallicRoughness"]
    spec = mat["extensions"]["KHR_materials_specular"]
    if "KHR_materials_specular" not in gltf.get("extensionsUsed", []):
        fail("KHR_materials_specular used but not declared")
    tex = lambda t: gltf["images"][gltf["textures"][t["index"]]["source"]]["name"]
    sampled = lambda t: pixels[gltf["textures"][t["index"]]["source"]]
    mr = sampled(pbr["metallicRoughnessTexture"])
    print(json.dumps({
        "vertices": int(count),
        "triangles": int(idx.size // 3),
        "position_min": pos.min(0).tolist(),
        "position_max": pos.max(0).tolist(),
        "uv_min": uv.min(0).tolist(),
        "uv_max": uv.max(0).tolist(),
        "base_color": tex(pbr["baseColorTexture"]),
        "metallic_roughness": tex(pbr["metallicRoughnessTexture"]),
        "metallic_factor": pbr.get("metallicFactor", 1.0),
        "normal": tex(mat["normalTexture"]),
        "specular": tex(spec["specularTexture"]),
        "images": len(gltf["images"]),
        # Mean values a glTF reader samples: base colour RGB (sRGB-encoded), roughness (G x roughnessFactor),
        # metallic (B x metallicFactor), specular strength (alpha x specularFactor), normal RGB.
        "base_color_mean": sampled(pbr["baseColorTexture"])[..., :3].mean((0, 1)).tolist(),
        "roughness_mean": float(mr[..., 1].mean() * pbr.get("roughnessFactor", 1.0)),
        "metallic_mean": float(mr[..., 2].mean() * pbr.get("metallicFactor", 1.0)),
        "specular_mean": float(sampled(spec["specularTexture"])[..., 3].mean() * spec.get("specularFactor", 1.0)),
        "normal_mean": sampled(mat["normalTexture"])[..., :3].mean((0, 1)).tolist(),
    }))


if __name__ == "__main__":
    main(sys.argv[1])
