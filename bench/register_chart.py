"""Speed-accuracy chart for bench/register.sh: rows.csv (label, noise, median, p95, seconds) -> PNG."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

rows = list(csv.reader(open(sys.argv[1])))
fig, ax = plt.subplots(figsize=(8, 4.8))
for i, (label, noise, median, p95, seconds) in enumerate(rows):
    x, y, noise = float(seconds), float(median), float(noise)
    color = "C3" if "anchor" in label else ("C2" if noise > 0 else "C0")
    ax.errorbar(x, y, yerr=[[0], [float(p95) - y]], fmt="o", capsize=3, color=color, alpha=0.8)
    text = f"noise {noise:.1f} mm" if noise > 0 else label
    ax.annotate(text, (x, y), textcoords="offset points", xytext=(6, -12 if i % 2 else 5), fontsize=7, color=color)
ax.axhline(0.5, color="grey", lw=0.8, ls="--")
ax.axvline(10, color="grey", lw=0.8, ls=":")
ax.set_xscale("log")
ax.set_xlabel("seconds per scan (2 in parallel, 2 cores)")
ax.set_ylabel("correspondence error, mm\n(median; bar to 95th percentile)")
ax.set_title("scan register on scan-synth truth, 65k template (dashed: 0.5 mm target; dotted: 10 s)", fontsize=9)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=120)
