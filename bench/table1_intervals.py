#!/usr/bin/env python3
"""Table 1's PSNR gains with BareSkinNet (with G minus without G) and their 95% intervals over subjects, from the
per_sample.csv of one or more `bareskin evaluate` reports.

Per subject, the mean gain over its faces; then the mean over subjects ± Student's t (n − 1 degrees of freedom) times
the standard error. Columns: (a) against the before-makeup output without G, (a') the same pipeline, (b) the truth.

    table1_intervals.py REPORT_DIR [REPORT_DIR ...]
"""
import csv
import os
import statistics
import sys

from scipy import stats

COLUMNS = (("reference", "(a)"), ("reference_same_pipeline", "(a')"), ("truth", "(b)"))
MAPS = ("diffuse", "roughness", "specular", "normal")


def gains(path):
    """(against, map) -> subject -> [gain per face]; (against, map) -> [(without, with) per face]."""
    rows = {}
    for r in csv.DictReader(open(path)):
        rows.setdefault((r["sample"], r["against"], r["map"]), {})[r["condition"]] = (r["subject"], float(r["psnr"]))
    by_subject, pairs = {}, {}
    for (_, against, m), v in rows.items():
        if "with" in v and "without" in v:
            subject = v["with"][0]
            by_subject.setdefault((against, m), {}).setdefault(subject, []).append(v["with"][1] - v["without"][1])
            pairs.setdefault((against, m), []).append((v["without"][1], v["with"][1]))
    return by_subject, pairs


def interval(per_subject):
    means = [statistics.mean(g) for g in per_subject.values()]
    n = len(means)
    if n < 2:
        return statistics.mean(means), float("nan"), n
    return statistics.mean(means), stats.t.ppf(0.975, n - 1) * statistics.stdev(means) / n ** 0.5, n


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    for report in sys.argv[1:]:
        by_subject, pairs = gains(os.path.join(report, "per_sample.csv"))
        print(f"{report}: PSNR with G − without G, mean over subjects ± 95% interval")
        print(f"{'column':6s} {'map':10s} {'without':>8s} {'with':>8s} {'gain':>16s} {'subjects':>8s}")
        for against, name in COLUMNS:
            for m in MAPS:
                if (against, m) not in by_subject:
                    continue
                g, half, n = interval(by_subject[(against, m)])
                without = statistics.mean(a for a, _ in pairs[(against, m)])
                with_ = statistics.mean(b for _, b in pairs[(against, m)])
                print(f"{name:6s} {m:10s} {without:8.2f} {with_:8.2f} {g:+8.2f} ± {half:5.2f} {n:8d}")


if __name__ == "__main__":
    main()
