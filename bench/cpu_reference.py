"""The CPU reference training's page (bench/cpu_reference.sh): learning curves and the held-out table.

Reads <out>/cpu.txt (CPU seconds per command), the runs' eval.csv (validation metrics by step: held-out subjects of the
val split) and the test split's scores (F/eval/metrics.json, G_seed*/eval_stage{1,2}.json). Writes <out>/curves.html
with its charts and prints the table as Markdown for bench/BENCHMARKS.md.
    python3 bench/cpu_reference.py <out/>
"""
import csv
import html
import json
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def cpu_seconds(out):
    total = defaultdict(float)
    path = os.path.join(out, "cpu.txt")
    if os.path.exists(path):
        for line in open(path):
            parts = line.split()
            if len(parts) == 4 and not line.startswith("Command"):
                total[parts[0]] += float(parts[1]) + float(parts[2])
    return total


def series(path, name):
    """(steps, values) of one metric in a run's long-format CSV (step,name,value); the last value per step wins."""
    points = {}
    if os.path.exists(path):
        for row in csv.DictReader(open(path)):
            if row["name"] == name:
                points[int(row["step"])] = float(row["value"])
    steps = sorted(points)
    return np.array(steps, dtype=float), np.array([points[s] for s in steps])


def g_curve(run, cpu, seed):
    """Validation PSNR against the bare truth over both stages: steps, CPU-minutes, G, the input."""
    s1, v1 = series(os.path.join(run, "stage1", "eval.csv"), "psnr_bare")
    s2, v2 = series(os.path.join(run, "stage2", "eval.csv"), "psnr_bare")
    _, i1 = series(os.path.join(run, "stage1", "eval.csv"), "psnr_input_bare")
    n1 = s1.max() if len(s1) else 0
    # CPU-minutes at a step: each stage's CPU time spread evenly over its steps (stage 2 steps cost more).
    c1 = cpu.get(f"G{seed}_stage1", 0) / 60 / max(n1, 1)
    n2 = s2.max() if len(s2) else 0
    c2 = cpu.get(f"G{seed}_stage2", 0) / 60 / max(n2, 1)
    steps = np.concatenate([s1, n1 + s2])
    # A stage without its CPU record (killed before it ended) has no CPU-minutes: NaN, not drawn on that axis.
    minutes = np.concatenate([s1 * c1 if c1 else s1 * np.nan, n1 * c1 + s2 * c2 if c2 else s2 * np.nan])
    return steps, minutes, np.concatenate([v1, v2]), (i1.mean() if len(i1) else float("nan")), n1


def main():
    out = sys.argv[1]
    cpu = cpu_seconds(out)
    seeds = [s for s in range(3) if os.path.isdir(os.path.join(out, f"G_seed{s}"))]
    curves = {s: g_curve(os.path.join(out, f"G_seed{s}"), cpu, s) for s in seeds}
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6), dpi=120)
    for ax, which, label in ((axes[0], 0, "steps (stage 1, then stage 2)"), (axes[1], 1, "CPU-minutes (2 cores)")):
        for s, c in curves.items():
            ax.plot(c[which], c[2], "-o", ms=2.5, lw=1.2, label=f"G, seed {s}")
        inputs = [c[3] for c in curves.values() if c[3] == c[3]]
        if inputs:
            ax.axhline(np.mean(inputs), color="grey", ls="--", lw=1, label="the input unchanged (do nothing)")
        for s, c in curves.items():
            if c[4]:
                switch = c[4] if which == 0 else c[1][len(c[1]) - len(c[2]) + int(np.searchsorted(c[0], c[4]))]
                ax.axvline(switch, color="#ccc", lw=0.8)
                break
        ax.set_xlabel(label)
        ax.set_ylabel("validation PSNR vs bare truth on skin (dB)")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.suptitle(f"BareSkinNet G, --profile cpu: held-out subjects (val split), {len(curves)} seed(s); grey line: "
                 "stage 1 → stage 2", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "curves_g.png"))

    rows = []
    for s in seeds:
        run = os.path.join(out, f"G_seed{s}")
        r = {"seed": s}
        for stage in (1, 2):
            p = os.path.join(run, f"eval_stage{stage}.json")
            if os.path.exists(p):
                j = json.load(open(p))
                r[stage] = j["mean"]
                r[f"style{stage}"] = j.get("by_style", {})
        r["cpu1"] = cpu.get(f"G{s}_stage1", 0) / 60
        r["cpu2"] = cpu.get(f"G{s}_stage2", 0) / 60
        rows.append(r)

    def fmt(x, n=2):
        return "—" if x is None or x != x else f"{x:.{n}f}"

    md = ["| G (`--profile cpu`) | PSNR vs bare (test) | SSIM | input | gain | `dramatic` PSNR (input) | CPU-min |",
          "|---|---|---|---|---|---|---|"]
    gains = {1: [], 2: []}
    for r in rows:
        for stage in (1, 2):
            m = r.get(stage)
            if not m:
                continue
            gain = m["psnr_bare"] - m["psnr_input_bare"]
            gains[stage].append(m["psnr_bare"])
            d = r[f"style{stage}"].get("dramatic", {})
            md.append(f"| seed {r['seed']}, stage {stage}{' (+ 1)' if stage == 2 else ''} | {fmt(m['psnr_bare'])} dB | "
                      f"{fmt(m.get('ssim_bare'), 3)} | {fmt(m['psnr_input_bare'])} dB | {gain:+.2f} dB | "
                      f"{fmt(d.get('psnr_bare'))} ({fmt(d.get('psnr_input_bare'))}) | "
                      f"{fmt(r['cpu1'] + (r['cpu2'] if stage == 2 else 0), 1)} |")
    for stage in (1, 2):
        if gains[stage]:
            g = np.array(gains[stage])
            md.append(f"| mean ± sd over {len(g)} seeds, stage {stage} | {g.mean():.2f} ± {g.std(ddof=1) if len(g) > 1 else 0:.2f} dB"
                      " | | | | | |")
    f_metrics = os.path.join(out, "F", "eval", "metrics.json")
    f_line = ""
    if os.path.exists(f_metrics):
        m = json.load(open(f_metrics))
        s = m["shape_mm"]
        ratio = s["median_per_face"] / s["mean_face_median_per_face"]
        f_line = (f"F (`train recon --profile cpu`, {fmt(cpu.get('F', 0) / 60, 1)} CPU-min): shape error "
                  f"{fmt(s['median_per_face'], 3)} mm per face (median), the mean face {fmt(s['mean_face_median_per_face'], 3)}"
                  f" mm: {ratio:.2f}× the mean face's")
        lm = m.get("landmark_px", {})
        if lm:
            f_line += f"; landmarks {fmt(lm.get('median'))} px (median, at {m.get('image_size', '?')}²)"
        f_line += f"; identity coefficients {fmt(m['alpha_sigma'])} σ (the mean face: 1)"
    table = "\n".join(md)
    print(table)
    if f_line:
        print("\n" + f_line)
    page = f"""<!doctype html><meta charset="utf-8"><title>BareSkin CPU reference training</title>
<style>body{{font:15px/1.45 system-ui,sans-serif;max-width:1100px;margin:2em auto}}img{{max-width:100%}}
pre{{background:#f6f6f6;padding:.8em}}</style>
<h1>CPU reference training (<code>--profile cpu</code>)</h1>
<p>World: <code>texgen faces</code> under {html.escape(out)}; validation curves on held-out subjects (val split), the
table on the test split (other held-out subjects; the <code>dramatic</code> makeup family appears only there). The
dashed line is the do-nothing baseline: the input unchanged. CPU-minutes are user + system time of each stage's command
on 2 cores, spread evenly over its steps.</p>
<img src="curves_g.png">
<h2>Held-out test split</h2><pre>{html.escape(table)}</pre>
<p>{html.escape(f_line)}</p>
"""
    open(os.path.join(out, "curves.html"), "w").write(page)
    print(f"\nwrote {os.path.join(out, 'curves.html')}", file=sys.stderr)


if __name__ == "__main__":
    main()
