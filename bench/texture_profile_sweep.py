"""Chart and table of bench/texture_profile_sweep.sh: each texture net's held-out PSNR per map against the CPU-minutes
of its training (the curve through its evaluations, CPU time taken as proportional to steps), with the 3DMM-only maps
and the UV net's start (the unwrap over the 3DMM albedo) drawn.
    python3 bench/texture_profile_sweep.py <out/> <name>...
"""
import csv
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cpu_profile_sweep import cpu_seconds  # noqa: E402

MAPS = ("diffuse", "normal", "roughness", "specular")


def evals(path):
    by_step = defaultdict(dict)
    for r in csv.DictReader(open(path)):
        by_step[int(r["step"])][r["name"]] = float(r["value"])
    return dict(sorted(by_step.items()))


def main():
    out, names = sys.argv[1], sys.argv[2:]
    cpu = cpu_seconds(out)
    runs = {n: evals(os.path.join(out, n, "eval.csv")) for n in names if os.path.exists(os.path.join(out, n, "eval.csv"))}
    runs = {n: e for n, e in runs.items() if e}
    if not runs:
        sys.exit(f"error: {out}: no run has an eval.csv; run bench/texture_profile_sweep.sh first")
    last = {n: e[max(e)] for n, e in runs.items()}
    best = max(v["psnr_diffuse"] for v in last.values())
    any_run = next(iter(last.values()))
    print("| texture net | CPU-min | diffuse | normal | roughness | specular | diffuse within 0.5 dB of the best |")
    print("|---|---|---|---|---|---|---|")
    for n, v in last.items():
        cells = " | ".join(f"{v['psnr_' + m]:.2f}" for m in MAPS)
        print(f"| {n} | {cpu[n] / 60:.1f} | {cells} | {'yes' if v['psnr_diffuse'] >= best - 0.5 else 'no'} |")
    cells = " | ".join(f"{any_run['psnr_mm_' + m]:.2f}" for m in MAPS)
    print(f"| 3DMM-only maps (albedo, flat normal, the truth's mean roughness and specular) | — | {cells} | |")
    print(f"| the unwrap over the 3DMM albedo (the UV net's start) | — | {any_run['psnr_unwrap_diffuse']:.2f} | | | | |")

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), dpi=120)
    for ax, m in zip(axes, ("diffuse", "roughness")):
        for n, e in runs.items():
            steps = list(e)
            minutes = [cpu[n] / 60 * s / steps[-1] for s in steps]
            ax.plot(minutes, [e[s]["psnr_" + m] for s in steps], "o-", ms=3, lw=1.2, label=n,
                    color="tab:orange" if n.startswith("uv") else "tab:blue", alpha=0.5 + 0.5 * ("ngf16" in n))
            ax.annotate(n, (minutes[-1], e[steps[-1]]["psnr_" + m]), textcoords="offset points", xytext=(3, 2),
                        fontsize=6)
        ax.axhline(any_run["psnr_mm_" + m], color="grey", ls="--", lw=1, label="3DMM-only maps")
        if m == "diffuse":
            ax.axhline(any_run["psnr_unwrap_diffuse"], color="grey", ls=":", lw=1, label="unwrap over 3DMM albedo")
        ax.set_xlabel("CPU-minutes of training (2 cores)")
        ax.set_ylabel(f"held-out PSNR, {m}, UV layout (dB)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=6, loc="lower right")
    fig.suptitle("Texture nets on held-out subjects: pix2pixHD's GlobalGenerator (blue) and the UV net (orange)",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "texture_profile_sweep.png"))


if __name__ == "__main__":
    main()
