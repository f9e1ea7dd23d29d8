#!/usr/bin/env python3
"""What holds Table 1's column (b), the output diffuse against the true maps, below 30 dB? Oracles on the CPU
reference's texture world, no texture net involved.

The texture net starts from the unwrap: the photo (through G) projected into the UV layout with F's fit, where the
photo saw the face. Its output cannot be much better than that unwrap on the texels the photo saw. This script builds
the unwraps `texgen run-dataset` gives for the test faces with makeup three ways and scores them against the true
diffuse:

  G + F            the run pipeline: the makeup photo through the reference's G, unwrapped with F's fit
  perfect G + F    the bare truth (a G that is exactly right) unwrapped with F's fit
  perfect G + fit  the bare truth unwrapped with mm-fit on the true landmarks (about the true geometry)

and, for each, on the texels the photo saw: the unwrap as it is, and with one per-face, per-channel gain fitted to
the truth (what knowing the light's level and tint would give); over the whole layout: the UV net's start (the unwrap
where seen, the 3DMM albedo elsewhere) with the albedo as it is and with the albedo matched to the unwrap's level
(the UV net's `"fill": "matched"`). Means over the held-out subjects with their 95% intervals.

  /usr/bin/python3 bench/texture_b_limits.py <bin/> <demo out/> <cpu_reference out/> <work/> [--max-samples N]
"""
import argparse
import glob
import io
import json
import os
import shutil
import subprocess
import sys
import tarfile

import numpy as np
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sr_ceiling import psnr  # noqa: E402
from table1_intervals import interval  # noqa: E402


def bare_as_makeup(src, dst):
    """A copy of the faces split whose makeup photo is its bare truth (what a perfect G hands on)."""
    os.makedirs(dst, exist_ok=True)
    shutil.copy(f"{src}/manifest.json", dst)
    for shard in sorted(glob.glob(f"{src}/*.tar")):
        with tarfile.open(shard) as t, tarfile.open(f"{dst}/{os.path.basename(shard)}", "w") as out:
            for m in t.getmembers():
                name = m.name.replace(".makeup.png", ".bare.png") if m.name.endswith(".makeup.png") else m.name
                data = t.extractfile(name).read()
                info = tarfile.TarInfo(m.name)
                info.size, info.mtime = len(data), m.mtime
                out.addfile(info, io.BytesIO(data))


def samples(dataset):
    """(subject, {member: pixels in [0, 1]}) of every sample with makeup of a run dataset."""
    for shard in sorted(glob.glob(f"{dataset}/*.tar")):
        with tarfile.open(shard) as t:
            for name in sorted(n for n in t.getnames() if n.endswith(".json")):
                key = name[:-5]
                maps = {m: np.asarray(Image.open(t.extractfile(f"{key}.{m}.png")), np.float64) / 255
                        for m in ("diffuse", "unwrap", "confidence", "mm_albedo")}
                meta = json.loads(t.extractfile(name).read())
                if meta["style"] != "none":  # as Table 1: faces without makeup are passed over
                    yield meta["subject"], maps


def scores(maps):
    truth, unwrap, albedo = maps["diffuse"], maps["unwrap"], maps["mm_albedo"]
    layout = albedo.sum(-1) > 0
    seen = (maps["confidence"] > 0) & layout
    best = (unwrap[seen] * truth[seen]).sum(0) / (unwrap[seen] ** 2).sum(0)
    matched = np.clip(albedo * unwrap[seen].sum(0) / albedo[seen].sum(0), 0, 1)
    s = seen[..., None]
    return [psnr(truth, unwrap, seen), psnr(truth, np.clip(unwrap * best, 0, 1), seen),
            psnr(truth, np.where(s, unwrap, albedo), layout), psnr(truth, np.where(s, unwrap, matched), layout),
            100 * seen.sum() / layout.sum()]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("bin"), p.add_argument("demo"), p.add_argument("ref"), p.add_argument("work")
    p.add_argument("--max-samples", type=int, default=0, help="at most this many faces (0: all)")
    a = p.parse_args()
    tex, model = f"{a.ref}/texture", f"{a.demo}/model/model.safetensors"
    for need in (f"{tex}/faces/test/manifest.json", f"{a.ref}/G_seed0/eval.json", f"{a.ref}/F/config.json", model):
        if not os.path.exists(need):
            sys.exit(f"texture_b_limits: {need} is missing; run bench/cpu_reference.sh first")
    os.makedirs(a.work, exist_ok=True)
    bare = f"{a.work}/bare_faces"
    if not os.path.exists(f"{bare}/manifest.json"):
        bare_as_makeup(f"{tex}/faces/test", bare)
    common = ["--textures", f"{tex}/data/test", "--model", model, "--max-samples", str(a.max_samples)]
    ways = {"G + F": [f"{tex}/faces/test", "--bareskin", f"{a.ref}/G_seed0", "--teacher", f"{a.ref}/F"],
            "perfect G + F": [bare, "--teacher", f"{a.ref}/F"],
            "perfect G + fit": [bare]}
    print("| unwrap | seen texels: as it is | with the best gain per face | layout: start, albedo fill | "
          "matched fill | seen, % of the layout |\n|---|---|---|---|---|---|")
    for i, (way, args) in enumerate(ways.items()):
        out = f"{a.work}/run_data_{i}"
        if not os.path.exists(f"{out}/manifest.json"):
            subprocess.run([f"{a.bin}/bareskin", "-q", "--threads", "2", "texgen", "run-dataset", "--faces", *args,
                            *common, "-o", out], check=True)
        by_subject = {}
        for subject, maps in samples(out):
            by_subject.setdefault(subject, []).append(scores(maps))
        cells = []
        for c in range(5):
            mean, half, n = interval({s: [row[c] for row in v] for s, v in by_subject.items()})
            cells.append(f"{mean:.2f} ± {half:.2f}" if c < 4 else f"{mean:.0f}")
        print(f"| {way} | " + " | ".join(cells) + " |")
    faces = sum(len(v) for v in by_subject.values())
    print(f"\n{faces} faces of {n} held-out subjects; dB, the mean over subjects ± its 95% interval (t).")


if __name__ == "__main__":
    main()
