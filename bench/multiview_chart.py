"""Speed-accuracy chart for bench/multiview_landmarks.sh: rows.csv (label, views, median 17-67, median jaw, seconds
per scan) -> PNG. One line per method over the number of views (the single front render is one point)."""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

rows = list(csv.reader(open(sys.argv[1])))
fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
for ax, column, title in ((axes[0], 2, "landmarks 17-67"), (axes[1], 3, "jaw contour 0-16")):
    for i, label in enumerate(dict.fromkeys(r[0] for r in rows)):
        pts = sorted((float(r[4]), float(r[column]), int(r[1])) for r in rows if r[0] == label)
        ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-" if len(pts) > 1 else "s", color=f"C{i}", label=label)
        for x, y, n in pts:
            ax.annotate(f"{n}", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=8)
    ax.axhline(2 if column == 2 else 4, color="grey", ls="--", lw=0.8)
    ax.set_yscale("log")
    ax.set_xlabel("seconds per scan (render + detect + triangulate, cpu-2c)")
    ax.set_ylabel("median error vs truth (mm)")
    ax.set_title(f"{title} (numbers: views; dashed: goal)")
    ax.grid(alpha=0.3)
axes[0].legend(fontsize=8)
fig.tight_layout()
fig.savefig(sys.argv[2], dpi=110)
