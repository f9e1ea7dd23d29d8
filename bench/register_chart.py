"""Speed-accuracy chart for bench/register.sh: rows.csv (label, noise, median, p95, seconds) -> PNG.
Each configuration is a numbered point (median, with a bar up to the 95th percentile); the numbers are listed beside
the plot, so labels never overlap. A label with "default" or "recommended" is a star.
Usage: register_chart.py ROWS.csv OUT.png [TITLE XLABEL TARGET_MM] (bench/register_texture_landmarks.sh gives them)."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

rows = list(csv.reader(open(sys.argv[1])))
title, xlabel, target = sys.argv[3:6] if len(sys.argv) > 5 else (
    "scan register on scan-synth truth, 65k template\n(dashed: 0.5 mm target; dotted: 10 s; star: default)",
    "seconds per scan (2 in parallel, 2 cores)", "0.5")
fig, (ax, key) = plt.subplots(1, 2, figsize=(11, 4.8), gridspec_kw={"width_ratios": [1.6, 1]})
lines = []
for i, (label, noise, median, p95, seconds) in enumerate(rows, 1):
    x, y, noise = float(seconds), float(median), float(noise)
    color = "C3" if "anchor" in label else ("C2" if noise > 0 else "C0")
    marker = "*" if ("default" in label or "recommended" in label) and noise == 0 else "o"
    ax.errorbar(x, y, yerr=[[0], [float(p95) - y]], fmt=marker, ms=12 if marker == "*" else 6, capsize=3,
                color=color, alpha=0.85)
    ax.annotate(str(i), (x, y), textcoords="offset points", xytext=(5, -11), fontsize=8, color=color)
    text = label + (f", noise {noise:.1f} mm" if noise > 0 else "")
    lines.append((f"{i:>2}  {text}: {y:.3f} / {float(p95):.3f} mm, {x:.1f} s", color))
ax.axhline(float(target), color="grey", lw=0.8, ls="--")
ax.axvline(10, color="grey", lw=0.8, ls=":")
ax.set_xscale("log")
ax.set_xlabel(xlabel)
ax.set_ylabel("correspondence error, mm\n(median; bar to 95th percentile)")
ax.set_title(title.replace("\\n", "\n"), fontsize=9)
key.axis("off")
for k, (text, color) in enumerate(lines):
    key.text(0, 1 - 0.075 * k, text, fontsize=8, color=color, va="top", family="monospace", transform=key.transAxes)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=120)
