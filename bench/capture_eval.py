#!/usr/bin/env python3
"""Scores `landmarks scan --capture` on a synthetic capture against its truth: the capture's true cameras
(`landmarks capture`: cameras.json) and the scan's landmarks (`scan synth`: landmarks.json). Prints one line:
cameras registered / photos, COLMAP's mean reprojection error, points on the head, ICP RMS, aligned camera centres
against the true ones (median / max mm), landmark error (median over all, 17-67, jaw 0-16), and writes it as JSON
with --json.
Usage: capture_eval.py OUT.json CAPTURE_DIR SCAN_DIR [--label NAME] [--json FILE]"""
import argparse, json
import numpy as np

ap = argparse.ArgumentParser()
ap.add_argument("result"); ap.add_argument("capture"); ap.add_argument("scan")
ap.add_argument("--label", default=""); ap.add_argument("--json", default="")
a = ap.parse_args()
doc = json.load(open(a.result))
truth = np.array(json.load(open(f"{a.scan}/landmarks.json"))["points"], dtype=float)
p = np.array([[np.nan] * 3 if q is None else q for q in doc["points"]], dtype=float)
d = np.linalg.norm(p - truth, axis=1)
row = {"label": a.label, "median_mm": float(np.nanmedian(d)), "inner_mm": float(np.nanmedian(d[17:])),
       "jaw_mm": float(np.nanmedian(d[:17]))}
cap = doc.get("capture")
if cap:
    true = {c["image"]: c for c in json.load(open(f"{a.capture}/cameras.json"))["cameras"]}
    centre = lambda c: -np.array(c["R"]).T @ np.array(c["t"])
    e = [np.linalg.norm(centre(c) - centre(true[c["image"]])) for c in cap["cameras"]]
    row.update(registered=cap["registered"], photos=cap["photos"], reprojection_px=cap.get("reprojection_px"),
               points=cap["points"], points_on_head=cap.get("points_on_head"), icp_rms_mm=cap["icp_rms_mm"],
               centre_median_mm=float(np.median(e)), centre_max_mm=float(np.max(e)))
    print(f"{a.label:24s} cameras {cap['registered']:3d}/{cap['photos']:<3d} reproj {cap.get('reprojection_px', 0):.2f} px  "
          f"points {cap['points']} ({cap.get('points_on_head', 0)} head)  ICP RMS {cap['icp_rms_mm']:.2f} mm  "
          f"centres {np.median(e):.2f}/{np.max(e):.2f} mm  landmarks {row['median_mm']:.2f} mm, 17-67 "
          f"{row['inner_mm']:.2f}, jaw {row['jaw_mm']:.2f}")
else:
    print(f"{a.label:24s} (no capture: virtual views)  landmarks {row['median_mm']:.2f} mm, 17-67 {row['inner_mm']:.2f}, "
          f"jaw {row['jaw_mm']:.2f}")
if a.json:
    json.dump(row, open(a.json, "w"), indent=1)
