#!/usr/bin/env python3
"""Scan landmarks against the truth: per-point errors of a `landmarks scan` output vs the scan's true landmarks.json
(`scan synth`). Usage: landmarks_eval.py TRUTH.json FOUND.json [...pairs] -> medians (all, 17-67, jaw 0-16), the
Spearman correlation of sigma_mm with the error, and one CSV row per point on --csv."""
import json, sys, statistics as st


def rank(v):
    order = sorted(range(len(v)), key=lambda i: v[i])
    r = [0.0] * len(v)
    for k, i in enumerate(order):
        r[i] = float(k)
    return r


def spearman(a, b):
    ra, rb = rank(a), rank(b)
    ma, mb = st.mean(ra), st.mean(rb)
    num = sum((x - ma) * (y - mb) for x, y in zip(ra, rb))
    den = (sum((x - ma) ** 2 for x in ra) * sum((y - mb) ** 2 for y in rb)) ** 0.5
    return num / den if den else float("nan")


args = sys.argv[1:]
csv = None
if "--csv" in args:
    k = args.index("--csv")
    csv = args[k + 1]
    del args[k:k + 2]
errs, sig, jaw, inner, missing = [], [], [], [], 0
rows = []
for t, f in zip(args[0::2], args[1::2]):
    truth = json.load(open(t))["points"]
    found = json.load(open(f))
    detail = found.get("detail", [{}] * 68)
    for i, (p, q) in enumerate(zip(truth, found["points"])):
        if q is None:
            missing += 1
            continue
        e = sum((a - b) ** 2 for a, b in zip(p, q)) ** 0.5
        (jaw if i < 17 else inner).append(e)
        s = detail[i].get("sigma_mm")
        if s is not None and s > 0:
            errs.append(e)
            sig.append(s)
        rows.append((f, i, e, s))
med = lambda v: st.median(v) if v else float("nan")
print(json.dumps({"median_all": med(jaw + inner), "median_17_67": med(inner), "median_jaw": med(jaw),
                  "p90_17_67": sorted(inner)[int(0.9 * len(inner))] if inner else float("nan"),
                  "spearman_sigma_error": spearman(sig, errs) if len(sig) > 2 else float("nan"),
                  "points": len(jaw) + len(inner), "missing": missing}))
if csv:
    with open(csv, "w") as o:
        o.write("file,index,error_mm,sigma_mm\n")
        for r in rows:
            o.write(",".join(str(x) for x in r) + "\n")
