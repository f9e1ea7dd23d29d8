#!/usr/bin/env python3
"""Subjects "registered" from the synthetic truth, without NICP: for each scan of a `scan synth` population, the
template mesh moved onto the scan through the truth's template-to-scan correspondence (template topology, the
template's UVs, normals dropped), and the truth maps baked in the template UV (`scan synth --truth-res`) copied
beside it. This is what `scan register` would output with zero error: the world of tests and benches that need
many subjects with true maps (texture inference) and not the registration itself.

    truth_registered.py TEMPLATE/face.obj SCANS/ OUT/ [MAP ...]     (maps: file names or globs, default diffuse.png)
"""
import glob
import os
import shutil
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from safetensors_oracle import read_safetensors  # noqa: E402


def moved_template(template_obj, correspondence):
    points = read_safetensors(correspondence)[1]["template_to_scan_point"]
    out, k = [], 0
    for line in open(template_obj):
        if line.startswith("vn "):
            continue
        if line.startswith("v "):
            line, k = "v %.7g %.7g %.7g\n" % tuple(points[k]), k + 1
        elif line.startswith("f "):  # the normals are dropped: so are the corners' references to them
            line = "f " + " ".join("/".join(c.split("/")[:2]) for c in line.split()[1:]) + "\n"
        out.append(line)
    if k != len(points):
        sys.exit(f"error: {correspondence}: {len(points)} points for a template of {k} vertices; "
                 "the scans were made from another template")
    return out


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    template_obj, scans, out = sys.argv[1:4]
    maps = sys.argv[4:] or ["diffuse.png"]
    subjects = sorted(glob.glob(os.path.join(scans, "subject_*")))
    if not subjects:
        sys.exit(f"error: {scans}: no subject_* folders; give a `scan synth` population")
    for subject in subjects:
        truth = os.path.join(subject, "truth")
        dest = os.path.join(out, os.path.basename(subject))
        os.makedirs(dest, exist_ok=True)
        for pattern in maps:
            found = glob.glob(os.path.join(truth, "maps", pattern))
            if not found:
                sys.exit(f"error: {truth}/maps: no {pattern}; make the scans with `scan synth --truth-res N`")
            for f in found:
                shutil.copy(f, dest)
        lines = moved_template(template_obj, os.path.join(truth, "correspondence.safetensors"))
        with open(os.path.join(dest, "mesh.obj.tmp"), "w") as f:
            f.writelines(lines)
        os.replace(os.path.join(dest, "mesh.obj.tmp"), os.path.join(dest, "mesh.obj"))


if __name__ == "__main__":
    main()
