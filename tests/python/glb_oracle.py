#!/usr/bin/env python3
"""Independent reader of a glTF 2.0 binary (.glb): parses the chunks with struct + json, checks the structure the
glTF 2.0 specification requires of what bareskin writes (header, chunk order and padding, buffer views inside the
buffer, accessors inside their views, POSITION bounds, index range, unit normals, PNG images, the PBR material and
KHR_materials_specular), and prints a JSON summary. Exits 1 with the reason on the first violation.
Usage: glb_oracle.py avatar.glb"""
import json
import struct
import sys

import numpy as np

COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}
DTYPES = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}


def fail(message):
    print("glb_oracle: " + message, file=sys.stderr)
    sys.exit(1)


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

    for i, image in enumerate(gltf["images"]):
        v = views[image["bufferView"]]
        png = binary[v.get("byteOffset", 0): v.get("byteOffset", 0) + v["byteLength"]]
        if image["mimeType"] != "image/png" or png[:8] != b"\x89PNG\r\n\x1a\n":
            fail(f"image {i} is not a PNG")
    mat = gltf["materials"][prim["material"]]
    pbr = mat["pbrMetallicRoughness"]
    spec = mat["extensions"]["KHR_materials_specular"]
    if "KHR_materials_specular" not in gltf.get("extensionsUsed", []):
        fail("KHR_materials_specular used but not declared")
    tex = lambda t: gltf["images"][gltf["textures"][t["index"]]["source"]]["name"]
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
    }))


if __name__ == "__main__":
    main(sys.argv[1])
