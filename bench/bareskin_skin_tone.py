#!/usr/bin/env python3
"""The recovered skin's error by skin tone: G's bare skin against the truth, per ITA group, on held-out subjects.

ITA (the individual typology angle, ITA° = atan((L* − 50) / b*), in degrees, of the mean skin colour in CIELAB) sorts
skin from very light (> 55°) through light (41–55), intermediate (28–41), tan (10–28) and brown (−30–10) to dark
(< −30). Each held-out subject gets the ITA of its true albedo (the mean over its samples' skin). Per group this
reports the PSNR and RMSE of G's output on the skin against the bare truth, with the input's, and the ITA error
|ITA(output) − ITA(truth)| against the input's: the input's ITA is that of the lit, made-up skin.

  extract <faces/> <photos/>           writes each test sample's makeup.png as <photos>/<key>.png
  report <faces/> <demakeup/> [--size 64] [--json F]
                                       reads `bareskin demakeup --aligned` outputs (<demakeup>/<key>/bare.png)

bench/bareskin_skin_tone.sh runs both around `bareskin demakeup`.
"""
import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from face_shards import member, png, split_samples, whole_footprint  # noqa: E402

# (name, lowest ITA°, highest): the outer groups take every angle beyond their bound.
GROUPS = [("very light", 55, float("inf")), ("light", 41, 55), ("intermediate", 28, 41), ("tan", 10, 28),
          ("brown", -30, 10), ("dark", -float("inf"), -30)]


def test_samples(faces):
    return split_samples(faces, "test", "bareskin_skin_tone")


def lab_l_b(rgb):
    """CIELAB L* and b* of sRGB colours [..., 3] (D65)."""
    c = np.where(rgb <= 0.04045, rgb / 12.92, ((rgb + 0.055) / 1.055) ** 2.4)
    m = np.array([[0.4124, 0.3576, 0.1805], [0.2126, 0.7152, 0.0722], [0.0193, 0.1192, 0.9505]])
    xyz = c @ m.T / np.array([0.9505, 1.0, 1.089])
    f = np.where(xyz > 0.008856, np.cbrt(xyz), 7.787 * xyz + 16 / 116)
    return 116 * f[..., 1] - 16, 200 * (f[..., 1] - f[..., 2])


def ita(rgb):
    L, b = lab_l_b(rgb)
    return float(np.degrees(np.arctan2(L - 50, b)))


def group_of(angle):
    return next(name for name, lo, hi in GROUPS if lo <= angle < hi)


def extract(a):
    os.makedirs(a.photos, exist_ok=True)
    n = 0
    for key, t, _ in test_samples(a.faces):
        with open(os.path.join(a.photos, key + ".png"), "wb") as f:
            f.write(t.extractfile(f"{key}.makeup.png").read())
        n += 1
    print(f"bareskin_skin_tone: {n} test photos in {a.photos}")


def mean_ci(values):
    v = np.asarray(values, np.float64)
    return float(v.mean()), float(1.96 * v.std(ddof=1) / np.sqrt(len(v))) if len(v) > 1 else float("nan")


def report(a):
    rows = []
    for key, t, meta in test_samples(a.faces):
        out = os.path.join(a.demakeup, key, "bare.png")
        if not os.path.exists(out):
            sys.exit(f"bareskin_skin_tone: {out} is missing; run `bareskin demakeup --aligned` on the extracted photos")
        get = lambda name: member(t, key, name, a.size)
        truth, photo, skin = get("bare"), get("makeup"), whole_footprint(get("skin"))
        with open(out, "rb") as f:
            g = png(f.read(), a.size)
        if skin.sum() < 16:
            continue
        err = lambda x: float(np.sqrt(((np.clip(x, 0, 1) - truth)[skin] ** 2).mean()))
        rows.append({"subject": meta["subject"], "style": meta["style"], "truth_rgb": truth[skin].mean(0),
                     "rmse": err(g), "rmse_input": err(photo),
                     "ita_g": ita(g[skin].mean(0)), "ita_input": ita(photo[skin].mean(0))})
    subject_ita = {}
    for r in rows:
        subject_ita.setdefault(r["subject"], []).append(r["truth_rgb"])
    subject_ita = {s: ita(np.mean(v, 0)) for s, v in subject_ita.items()}
    table = []
    print(f"held-out subjects of {a.faces}: {len(subject_ita)}, samples {len(rows)}, compared at {a.size}² on the skin")
    print("| ITA group | subjects | samples | PSNR G (dB) | PSNR input | RMSE G | ITA error G (°) | ITA error input (°) |")
    print("|---|---|---|---|---|---|---|---|")
    for name, lo, hi in GROUPS:
        subjects = [s for s, v in subject_ita.items() if group_of(v) == name]
        if not subjects:
            continue
        per = lambda f: [np.mean([f(r) for r in rows if r["subject"] == s]) for s in subjects]
        psnr = lambda e: -20 * np.log10(e)
        truth_ita = lambda r: subject_ita[r["subject"]]
        g = {"subjects": len(subjects), "samples": sum(r["subject"] in subjects for r in rows),
             "psnr": mean_ci(per(lambda r: psnr(r["rmse"]))), "psnr_input": mean_ci(per(lambda r: psnr(r["rmse_input"]))),
             "rmse": mean_ci(per(lambda r: r["rmse"])),
             "ita_error": mean_ci(per(lambda r: abs(r["ita_g"] - truth_ita(r)))),
             "ita_error_input": mean_ci(per(lambda r: abs(r["ita_input"] - truth_ita(r))))}
        table.append((name, g))
        f = lambda m: f"{m[0]:.2f} ± {m[1]:.2f}"
        print(f"| {name} ({lo:g}…{hi:g}°) | {g['subjects']} | {g['samples']} | {f(g['psnr'])} | {f(g['psnr_input'])} | "
              f"{g['rmse'][0]:.4f} | {f(g['ita_error'])} | {f(g['ita_error_input'])} |")
    enough = [(n, g) for n, g in table if g["subjects"] >= a.min_subjects]
    worst = max(g["rmse"][0] for _, g in enough) if enough else float("nan")
    best = min(g["rmse"][0] for _, g in enough) if enough else float("nan")
    ita_g = np.mean([abs(r["ita_g"] - subject_ita[r["subject"]]) for r in rows])
    ita_in = np.mean([abs(r["ita_input"] - subject_ita[r["subject"]]) for r in rows])
    summary = {"groups_with_enough_subjects": len(enough), "min_subjects": a.min_subjects,
               "worst_over_best_rmse": worst / best, "ita_error": ita_g, "ita_error_input": ita_in,
               "ita_error_ratio": ita_g / ita_in}
    print(f"\ngroups with ≥ {a.min_subjects} subjects: {len(enough)}; worst group's RMSE / best's: "
          f"{summary['worst_over_best_rmse']:.2f}; ITA error {ita_g:.2f}° vs the input's {ita_in:.2f}° "
          f"(× {summary['ita_error_ratio']:.2f})")
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"groups": dict(table), "summary": summary, "faces": a.faces, "size": a.size}, f, indent=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = ap.add_subparsers(dest="command", required=True)
    e = sub.add_parser("extract")
    e.add_argument("faces")
    e.add_argument("photos")
    r = sub.add_parser("report")
    r.add_argument("faces")
    r.add_argument("demakeup")
    r.add_argument("--size", type=int, default=64, help="compare at this size (G's working size)")
    r.add_argument("--min-subjects", type=int, default=5, help="a group counts towards the ratio with this many")
    r.add_argument("--json")
    a = ap.parse_args()
    extract(a) if a.command == "extract" else report(a)


if __name__ == "__main__":
    main()
