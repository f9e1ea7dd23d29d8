#!/usr/bin/python3
"""Same pixels, not necessarily the same bytes: two output folders (or two files) of a command before and after a
change of the PNG encoding. PNG files are compared decoded (shape, bit depth and every value); GLB files by their
JSON, their non-image buffer bytes and each embedded image decoded; viewer.html by its text with the inlined data
replaced, and the inlined GLB and images as above; makeup_report.json without its seconds and paths; any other file by
its bytes. Prints one line per difference and exits 1 if there is any.
Usage: bench/same_pixels.py BEFORE AFTER"""
import base64
import io
import json
import os
import re
import struct
import sys

import numpy as np
from PIL import Image


def pixels(data):
    im = Image.open(io.BytesIO(data))
    return im.mode, np.asarray(im)


def same_png(a, b):
    (ma, pa), (mb, pb) = pixels(a), pixels(b)
    return ma == mb and pa.shape == pb.shape and pa.dtype == pb.dtype and np.array_equal(pa, pb)


def glb_parts(data):
    """The JSON (image bufferViews' offsets and lengths dropped), the non-image bytes and the images of a GLB."""
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + length])
    binary = data[20 + length + 8:]
    image_views = {img["bufferView"] for img in doc.get("images", [])}
    images = [binary[v["byteOffset"]:v["byteOffset"] + v["byteLength"]]
              for i, v in enumerate(doc["bufferViews"]) if i in image_views]
    rest = b"".join(binary[v.get("byteOffset", 0):v.get("byteOffset", 0) + v["byteLength"]]
                    for i, v in enumerate(doc["bufferViews"]) if i not in image_views)
    for i in image_views:
        doc["bufferViews"][i].pop("byteOffset", None)
        doc["bufferViews"][i].pop("byteLength", None)
    for v in doc["bufferViews"]:
        v.pop("byteOffset", None)
    doc["buffers"] = len(doc.get("buffers", []))
    return doc, rest, images


def same_glb(a, b):
    da, ra, ia = glb_parts(a)
    db, rb, ib = glb_parts(b)
    return da == db and ra == rb and len(ia) == len(ib) and all(same_png(x, y) for x, y in zip(ia, ib))


URI = re.compile(r'data:image/png;base64,([A-Za-z0-9+/=]+)|"glb": ?"([A-Za-z0-9+/=]+)"')


def same_html(a, b):
    ta, tb = a.decode(), b.decode()
    ba, bb = URI.findall(ta), URI.findall(tb)
    if URI.sub("@", ta) != URI.sub("@", tb) or len(ba) != len(bb):
        return False
    for (pa, ga), (pb, gb) in zip(ba, bb):
        if bool(pa) != bool(pb):
            return False
        if pa and not same_png(base64.b64decode(pa), base64.b64decode(pb)):
            return False
        if ga and not same_glb(base64.b64decode(ga), base64.b64decode(gb)):
            return False
    return True


def report(data):
    doc = json.loads(data)
    doc.pop("seconds", None)
    doc.pop("avatar", None)
    for look in doc.get("looks", []):
        for k in ("seconds_apply", "seconds_total", "folder"):
            look.pop(k, None)
    return doc


def same(path_a, path_b):
    a, b = open(path_a, "rb").read(), open(path_b, "rb").read()
    name = os.path.basename(path_a)
    if name.endswith(".png"):
        return same_png(a, b)
    if name.endswith(".glb"):
        return same_glb(a, b)
    if name.endswith(".html"):
        return same_html(a, b)
    if name == "makeup_report.json":
        return report(a) == report(b)
    return a == b


def files(root):
    if os.path.isfile(root):
        return {"": root}
    return {os.path.relpath(os.path.join(d, f), root): os.path.join(d, f)
            for d, _, names in os.walk(root) for f in names}


def main():
    fa, fb = files(sys.argv[1]), files(sys.argv[2])
    bad = sorted(set(fa) ^ set(fb))
    for rel in bad:
        print(f"only in one: {rel}")
    for rel in sorted(set(fa) & set(fb)):
        if not same(fa[rel], fb[rel]):
            print(f"differs: {rel}")
            bad.append(rel)
    print(f"{len(set(fa) & set(fb))} files compared, {len(bad)} differ")
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
