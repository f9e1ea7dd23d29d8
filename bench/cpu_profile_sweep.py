"""Chart and table of bench/cpu_profile_sweep.sh: held-out PSNR of each G variant against its CPU-minutes.
    python3 bench/cpu_profile_sweep.py <out/> <name>...
"""
import json
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def cpu_seconds(out):
    """CPU seconds (user + system) per name of <out>/cpu.txt (lines "NAME user system wall" of /usr/bin/time)."""
    cpu = defaultdict(float)
    for line in open(os.path.join(out, "cpu.txt")):
        parts = line.split()
        if len(parts) == 4 and not line.startswith("Command"):
            cpu[parts[0]] += float(parts[1]) + float(parts[2])
    return cpu


def main():
    out, names = sys.argv[1], sys.argv[2:]
    cpu = cpu_seconds(out)
    rows = []
    for n in names:
        p = os.path.join(out, n, "eval.json")
        if not os.path.exists(p):
            continue
        j = json.load(open(p))
        m = j["mean"]
        rows.append((n, cpu[n] / 60, m["psnr_bare"], m.get("psnr_face_bare", float("nan")),
                     m.get("psnr_makeup_bare", float("nan")), m["psnr_input_bare"], m.get("psnr_face_input_bare", float("nan")),
                     m.get("psnr_makeup_input_bare", float("nan")), j["ms_per_image"]))
    best = max(r[2] for r in rows)
    print("| G (stage 1) | CPU-min | PSNR skin | PSNR face | PSNR makeup region | input skin / face / makeup | G ms | within 0.5 dB of the best |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r[0]} | {r[1]:.1f} | {r[2]:.2f} | {r[3]:.2f} | {r[4]:.2f} | {r[5]:.2f} / {r[6]:.2f} / {r[7]:.2f} | "
              f"{r[8]:.1f} | {'yes' if r[2] >= best - 0.5 else 'no'} |")
    fig, ax = plt.subplots(figsize=(6, 3.8), dpi=120)
    for r in rows:
        ax.plot(r[1], r[2], "o", color="tab:orange" if r[0].startswith("affine") else "tab:blue")
        ax.annotate(r[0], (r[1], r[2]), textcoords="offset points", xytext=(4, 3), fontsize=7)
    ax.axhline(rows[0][5], color="grey", ls="--", lw=1, label="the input unchanged")
    ax.set_xlabel("CPU-minutes of training (2 cores)")
    ax.set_ylabel("held-out PSNR vs bare truth, skin (dB)")
    ax.set_title("G variants, the same stage-1 steps (--profile cpu otherwise)", fontsize=9)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "cpu_profile_sweep.png"))


if __name__ == "__main__":
    main()
