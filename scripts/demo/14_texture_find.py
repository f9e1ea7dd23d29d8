#!/usr/bin/env python3
"""Helpers of demo §14 (scripts/demo/14_texture.sh).
  14_texture_find.py OUT                      shell assignments: the texture splits, masks, held-out faces, the
                                              BareSkinNet run and the reconstruction run F under OUT, found by manifest
                                              kind/split and checkpoint task
  14_texture_find.py --extract FACES PNG [SUBJECT]   the first sample's makeup.png of a faces split (of SUBJECT)
  14_texture_find.py --subjects SPLIT         the subjects of a shard split (json "subject"), one a line, sorted
  14_texture_find.py --split-of FACES SUBJECT the split folder of a faces set (FACES/{train,val,test}) that holds
                                              SUBJECT's samples
  14_texture_find.py --report OUT DIR RES STEPS UP_STEPS SAMPLES   figures into OUT/img, the HTML
                                              fragment on stdout"""
import csv
import glob
import html
import json
import os
import struct
import sys
import tarfile


def checkpoint_task(path):
    try:
        with open(path, "rb") as f:
            n = struct.unpack("<Q", f.read(8))[0]
            header = json.loads(f.read(n))
        return json.loads(header["__metadata__"]["bareskin.checkpoint"])["task"]
    except Exception:
        return None


def find(out):
    found = {}
    for manifest in sorted(glob.glob(os.path.join(out, "**", "manifest.json"), recursive=True)):
        try:
            meta = json.load(open(manifest)).get("metadata", {})
        except Exception:
            continue
        folder = os.path.dirname(manifest)
        kind, split = meta.get("kind"), meta.get("split")
        if kind == "texture" and split in ("train", "val", "test"):
            found.setdefault("TEX_" + split.upper(), folder)
        elif kind == "mask":
            found.setdefault("TEX_MASKS", folder)
        elif kind in ("faces", "face") and split == "test":
            found.setdefault("FACES_TEST", folder)
        elif split == "test" and os.path.basename(os.path.dirname(folder)).startswith("faces"):
            found.setdefault("FACES_TEST", folder)
    for ckpt in sorted(glob.glob(os.path.join(out, "**", "checkpoint.safetensors"), recursive=True)):
        task = checkpoint_task(ckpt)
        if task == "recon":
            found.setdefault("RECON_RUN", os.path.dirname(ckpt))
        if task == "bareskinnet":
            run = os.path.dirname(ckpt)
            if os.path.basename(run) in ("stage1", "stage2"):
                run = os.path.dirname(run)
            found.setdefault("BSN_RUN", run)
    for key, value in found.items():
        print(f"{key}='{value}'")


def first_sample(faces, subject=None):
    """The members of the first sample of a faces split (of `subject`, when given), by suffix."""
    manifest = json.load(open(os.path.join(faces, "manifest.json")))
    for shard in manifest["shards"]:
        with tarfile.open(os.path.join(faces, shard["name"])) as tar:
            samples = {}
            for member in tar:
                key, _, suffix = member.name.partition(".")
                samples.setdefault(key, {})[suffix] = tar.extractfile(member).read()
            for members in samples.values():
                if "json" in members and (subject is None or json.loads(members["json"]).get("subject") == subject):
                    return members
    sys.exit(f"error: {faces}: no sample{' of ' + subject if subject else ''}")


def extract(faces, png, subject=None):
    """The first sample's makeup.png (of `subject`, when given), its landmarks (aligned px) beside it as
    <png stem>_lm.json and its bare-skin truth as <png stem>_bare.png."""
    members = first_sample(faces, subject)
    if "makeup.png" not in members:
        sys.exit(f"error: {faces}: the sample has no makeup.png")
    open(png, "wb").write(members["makeup.png"])
    if "bare.png" in members:
        open(png[:-4] + "_bare.png", "wb").write(members["bare.png"])
    points = json.loads(members["json"])["landmarks"]
    json.dump({"scheme": "ibug68", "units": "px", "points": points}, open(png[:-4] + "_lm.json", "w"))


def split_subjects(split):
    subjects = set()
    manifest = json.load(open(os.path.join(split, "manifest.json")))
    for shard in manifest["shards"]:
        with tarfile.open(os.path.join(split, shard["name"])) as tar:
            for member in tar:
                if member.name.endswith(".json"):
                    subjects.add(json.loads(tar.extractfile(member).read()).get("subject", ""))
    return sorted(s for s in subjects if s)


def split_of(faces, subject):
    for split in ("test", "val", "train"):
        folder = os.path.join(faces, split)
        if os.path.exists(os.path.join(folder, "manifest.json")) and subject in split_subjects(folder):
            return folder
    sys.exit(f"error: {faces}: no split holds {subject}")


def tile(path, size=150, grey=False):
    import numpy as np
    from PIL import Image
    image = Image.open(path)
    if image.mode.startswith("I"):  # 16-bit (the registered scans' grey maps): to 8 bits
        image = Image.fromarray((np.asarray(image, dtype=np.float64) / 257).clip(0, 255).astype(np.uint8))
    image = image.convert("L").convert("RGB") if grey else image.convert("RGB")
    return image.resize((size, size), Image.BILINEAR)


def strip(columns, target):
    from PIL import Image, ImageDraw
    size, label_h = 150, 16
    sheet = Image.new("RGB", (size * len(columns), size + label_h), "white")
    draw = ImageDraw.Draw(sheet)
    for i, (label, path, grey) in enumerate(columns):
        if path and os.path.exists(path):
            sheet.paste(tile(path, size, grey), (i * size, label_h))
        draw.text((i * size + 4, 2), label, fill="black")
    sheet.save(target)


def avatar_columns(a):
    return [("input (aligned)", f"{a}/aligned.png", False), ("bare skin", f"{a}/bare.png", False),
            ("3DMM fit", f"{a}/fit.png", False), ("diffuse", f"{a}/maps/diffuse.png", False),
            ("normal", f"{a}/maps/normal.png", False), ("roughness", f"{a}/maps/roughness.png", True),
            ("specular", f"{a}/maps/specular.png", True), ("relit 1", f"{a}/preview_light1.png", False),
            ("relit 2", f"{a}/preview_light2.png", False), ("relit 3", f"{a}/preview_light3.png", False)]


def variant_strips(d, img, name, caption):
    """The strips of the avatar folders <d>/avatar_<name>_{with,without} that exist, as HTML figures."""
    rows = []
    for variant in ("with", "without"):
        a = os.path.join(d, f"avatar_{name}_{variant}")
        if os.path.isdir(a):
            target = os.path.join(img, f"texture_{name}_{variant}.png")
            strip(avatar_columns(a), target)
            rows.append(f"<figure><img src='img/{os.path.basename(target)}' style='width:100%;max-width:1500px'>"
                        f"<figcaption>{caption}{variant} BareSkinNet</figcaption></figure>")
    return rows


def last_eval(run):
    values = {}
    path = os.path.join(run, "eval.csv")
    if os.path.exists(path):
        for row in csv.DictReader(open(path)):
            values[row["name"]] = float(row["value"])
    return values


def md_table_to_html(md):
    rows = [l for l in md.splitlines() if l.startswith("|") and not l.startswith("|---")]
    text = [l for l in md.splitlines() if l and not l.startswith("|")]
    out = "<table border=1 cellpadding=3 style='border-collapse:collapse'>"
    for i, r in enumerate(rows):
        cells = [c.strip() for c in r.strip("|").split("|")]
        tag = "th" if i == 0 else "td"
        out += "<tr>" + "".join(f"<{tag}>{html.escape(c)}</{tag}>" for c in cells) + "</tr>"
    return out + "</table>" + "".join(f"<p>{html.escape(t)}</p>" for t in text)


def report(out, d, res, steps, up_steps, samples):
    img = os.path.join(out, "img")
    rel = os.path.relpath(d, out)
    parts = [f"<h2>14. Texture inference: the UV net, SRGAN ×4, <code>bareskin run</code>, Table 1</h2>",
             f"<p>Demo sizes, the CPU profiles (<code>--profile cpu</code>, docs/texture.md) shortened to fit about "
             f"110 s on 2 cores: the texture net is the UV net (a U-Net of width 16 that corrects the unwrap over the "
             f"3DMM albedo, a flat normal and grey roughness and specular; L1 on the UV layout, no discriminator) at "
             f"{res}² maps, {steps} steps of batch 4; SRGAN ×4 on the diffuse (MSRResNet 16 features, 4 blocks, a "
             f"residual over bicubic that starts at bicubic) {up_steps} MSE steps at Adam 2e-3 falling linearly to "
             "0, on 128² crops of batch 2. The paper's pix2pixHD and SRGAN are <code>--profile paper</code>, at 1K → 4K. "
             "The validation split holds subjects the nets never saw.</p>"]
    run_data = os.path.join(d, "run_data", "train", "manifest.json")
    if os.path.exists(run_data):
        meta = json.load(open(run_data)).get("metadata", {})
        parts.append(f"<p>The texture net trains on <code>texgen run-dataset</code> samples: {meta.get('samples')} "
                     f"photos of the {len(meta.get('subjects', []))} texture training subjects (makeup, light, pose, "
                     "occluders) through G of §12 and the coefficients of §11, unwrapped as <code>run</code> unwraps "
                     "them and paired with the true maps; it is validated the same way on the validation subject's "
                     f"photos. Those unwraps score {meta.get('unwrap_psnr_db', float('nan')):.2f} dB against the true "
                     "diffuse where they see the face. SRGAN trains on make-dataset's true maps.</p>")
    tex = os.path.join(d, "tex")
    ev = last_eval(tex)
    if ev and "psnr_mm_diffuse" in ev:
        cells = "".join(f"<tr><td>{m}</td><td>{ev['psnr_' + m]:.2f}</td><td>{ev['psnr_mm_' + m]:.2f}</td></tr>"
                        for m in ("diffuse", "normal", "roughness", "specular"))
        parts.append("<table><tr><th>held-out map (val subjects)</th><th>UV net, PSNR dB</th><th>3DMM-only maps "
                     "(albedo, flat normal, the truth's mean roughness and specular)</th></tr>" + cells + "</table>"
                     "<p>The unwrap over the 3DMM albedo as it is (the UV net's start with the default fill; the "
                     "profile's net starts from that albedo matched to the unwrap's level) scores "
                     f"{ev['psnr_unwrap_diffuse']:.2f} dB on the diffuse. The synthetic scans' normal maps are flat "
                     "at this size, so the flat normal is already the truth.</p>")
    grids = sorted(glob.glob(os.path.join(tex, "samples", "step_*.png")))
    parts.append(f"<figure><img src='{rel}/tex/losses.svg' style='width:420px'><figcaption>texture net loss (L1 on the "
                 "UV layout)</figcaption></figure>")
    if grids:
        parts.append(f"<figure><img src='{os.path.relpath(grids[-1], out)}' style='width:420px'><figcaption>validation "
                     "samples, last step: rows unwrap | 3DMM albedo | output | truth (diffuse); confidence | 3DMM "
                     "normal | output | truth (normal); roughness output | truth | specular output | truth"
                     "</figcaption></figure>")
    up = last_eval(os.path.join(d, "up"))
    parts.append(f"<figure><img src='{rel}/up/losses.svg' style='width:420px'><figcaption>SRGAN loss (MSE)"
                 "</figcaption></figure>")
    if up:
        parts.append(f"<p>SRGAN ×4 on the held-out (val) diffuse map, 1024² from its 256² box-filtered version: bicubic "
                     f"{up.get('psnr_bicubic', float('nan')):.2f} dB, SRGAN {up.get('psnr_srgan', float('nan')):.2f} dB "
                     "(the largest maps the demo data has; the paper's are 4K).</p>")
    rows = variant_strips(d, img, "heldout", "held-out face with makeup, ")
    if rows:
        parts.append("<p>End to end on a held-out synthetic face with makeup (<code>bareskin run</code> on its aligned "
                     "makeup image): input | bare skin | 3DMM fit | the four maps | relit under three lights.</p>")
        parts += rows
    truth_rows = variant_strips(d, img, "truth", "")
    if truth_rows:
        subject = open(os.path.join(d, "truth_subjects.txt")).read().split()[0]
        maps = os.path.join(out, "registered", subject)
        target = os.path.join(img, "texture_truth.png")
        strip([("input (aligned)", os.path.join(d, "truth_face.png"), False),
               ("bare skin, truth", os.path.join(d, "truth_face_bare.png"), False), ("", None, False)] +
              [(f"{m}, truth", os.path.join(maps, f"{m}.png"), m in ("roughness", "specular"))
               for m in ("diffuse", "normal", "roughness", "specular")], target)
        truth_rows.append("<figure><img src='img/texture_truth.png' style='width:100%;max-width:1500px'>"
                          f"<figcaption>the truth: the face's bare skin and {html.escape(subject)}'s true maps"
                          "</figcaption></figure>")
        parts.append("<p>A face of the texture test subject (held out from the texture net and SRGAN) with makeup, "
                     "with and without BareSkinNet, and the truth.</p>")
        parts += truth_rows
    t1 = os.path.join(d, "table1", "table.md")
    if os.path.exists(t1):
        parts.append(f"<h3>Table 1 at demo size ({samples} held-out samples)</h3>"
                     "<p>Two readings of the paper's reference (the maps of the before-makeup image): (a) the before "
                     "image through the pipeline without G, one reference for both rows — anything G changes besides "
                     "the makeup (e.g. removing the light) counts as error; (a&prime;) the before image through the "
                     "row's own pipeline (with G for the with-G row) — how far makeup moves the maps, what the paper "
                     "says the table shows; a G that erased everything would win it, so read it with column (b) "
                     "(docs/texture.md).</p>" + md_table_to_html(open(t1).read()))
        parts.append(f"<figure><img src='{rel}/table1/psnr.svg' style='width:420px'></figure>")
    else:
        parts.append("<p>Table 1 needs a BareSkinNet run and held-out faces from the earlier sections; not run.</p>")
    t1b = os.path.join(d, "table1_truth", "table.md")
    if os.path.exists(t1b):
        subjects = ", ".join(html.escape(s) for s in open(os.path.join(d, "truth_subjects.txt")).read().split())
        parts.append(f"<h3>Table 1 against the true maps (column b): faces of the texture test subject ({subjects})</h3>"
                     "<p>The held-out faces above belong to subjects without true maps in the texture test split, so "
                     "column (b) is measured on faces rendered here (<code>texgen faces</code>, the texture test "
                     "subject only, new makeup, light and pose draws): held out from the texture net and SRGAN; at demo "
                     "size the faces and texture splits are drawn separately, so BareSkinNet may have seen other "
                     "images of this subject.</p>" + md_table_to_html(open(t1b).read()))
    a = os.path.join(d, "avatar_astronaut")
    if os.path.isdir(a):
        target = os.path.join(img, "texture_astronaut.png")
        strip(avatar_columns(a), target)
        rep = json.load(open(os.path.join(a, "report.json")))
        parts.append("<p><code>bareskin run astronaut.png -o avatar/</code> (scikit-image's astronaut; "
                     f"{'with' if rep.get('bareskin') else 'without'} BareSkinNet, coefficients by "
                     f"{'the network F' if rep.get('coefficients_from') == 'F' else 'mm-fit'}): "
                     f"{rep['pipeline_seconds']:.1f} s for the pipeline after loading ({rep['load_seconds']:.1f} s), "
                     f"maps {rep['sizes']['maps']}² and {rep['sizes']['maps_hr']}² ({html.escape(rep['upscaled_with'])})"
                     "; the folder holds mesh.obj, avatar.glb (PBR, KHR_materials_specular), the maps, bare.png, "
                     "coefficients.json and the previews.</p>"
                     f"<figure><img src='img/texture_astronaut.png' style='width:100%;max-width:1500px'></figure>")
    print("\n".join(parts))


if __name__ == "__main__":
    if sys.argv[1] == "--extract":
        extract(*sys.argv[2:5])
    elif sys.argv[1] == "--subjects":
        print("\n".join(split_subjects(sys.argv[2])))
    elif sys.argv[1] == "--split-of":
        print(split_of(sys.argv[2], sys.argv[3]))
    elif sys.argv[1] == "--report":
        report(*sys.argv[2:9])
    else:
        find(sys.argv[1])
