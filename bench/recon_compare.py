#!/usr/bin/env python3
"""Two `bareskin recon --eval` runs on the same held-out split, compared per subject: the mean change of the shape
error per face (run B − run A, mm) with a 95% bootstrap interval over subjects, and how many subjects improved.
Usage: python3 bench/recon_compare.py <texgen faces split> <eval A> <eval B>"""
import csv, glob, json, sys, tarfile

import numpy as np

split, eval_a, eval_b = sys.argv[1:4]
subject = {}
for shard in glob.glob(split + "/*.tar"):
    with tarfile.open(shard) as tar:
        for member in tar.getmembers():
            if member.name.endswith(".json"):
                subject[member.name[:-5]] = str(json.load(tar.extractfile(member))["subject"])
def shape(run):
    return {row["key"]: float(row["shape_mm"]) for row in csv.DictReader(open(run + "/faces.csv"))}
a, b = shape(eval_a), shape(eval_b)
subjects = sorted({subject[k] for k in a})
change = np.array([np.mean([b[k] - a[k] for k in a if subject[k] == s]) for s in subjects])
rng = np.random.default_rng(0)
boot = [change[rng.integers(0, len(change), len(change))].mean() for _ in range(10000)]
lo, hi = np.percentile(boot, [2.5, 97.5])
print(f"{len(subjects)} subjects: shape error per face {change.mean():+.3f} mm (95% [{lo:+.3f}, {hi:+.3f}]), "
      f"{(change < 0).sum()} of {len(subjects)} subjects improved")
