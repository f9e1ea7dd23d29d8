"""Speed-accuracy chart for bench/register.sh: rows.csv (label, noise, median, p95, seconds) -> PNG."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

rows = list(csv.reader(open(sys.argv[1])))
fig, ax = plt.subplots(figsize=(7.5, 4.5))
for label, noise, median, p95, seconds in rows:
    x, y = float(seconds), float(median)
    ax.errorbar(x, y, yerr=[[0], [float(p95) - y]], fmt="o", capsize=3, color="C3" if "anchor" in label else "C0")
    ax.annotate(f"{label}, noise {float(noise):.1f}", (x, y), textcoords="offset points", xytext=(6, 4), fontsize=7)
ax.axhline(0.5, color="grey", lw=0.8, ls="--")
ax.axvline(10, color="grey", lw=0.8, ls=":")
ax.set_xscale("log")
ax.set_xlabel("seconds per scan (2 in parallel, 2 cores)")
ax.set_ylabel("correspondence error vs truth, mm (median; bar to p95)")
ax.set_title("scan register: speed and accuracy (65k template; dashed: 0.5 mm target, dotted: 10 s)")
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=120)
