"""Learning curves of bench/cpu_reference_texture.sh: the texture net's held-out PSNR per map against its steps, with
the 3DMM-only maps and the unwrap it starts from, and each SRGAN's held-out PSNR against bicubic.
    python3 bench/cpu_reference_texture.py <out/>     (writes <out>/curves_texture.png)
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from texture_profile_sweep import evals  # noqa: E402  (eval.csv by step)


def main():
    out = sys.argv[1]
    tex = evals(os.path.join(out, "tex", "eval.csv"))
    if not tex:
        sys.exit(f"error: {out}/tex/eval.csv is empty; run bench/cpu_reference_texture.sh first")
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), dpi=120)
    steps = list(tex)
    for m, color in (("diffuse", "tab:orange"), ("roughness", "tab:green"), ("specular", "tab:purple")):
        axes[0].plot(steps, [tex[s]["psnr_" + m] for s in steps], "o-", ms=3, color=color, label=f"UV net, {m}")
        axes[0].axhline(tex[steps[-1]]["psnr_mm_" + m], color=color, ls="--", lw=1, label=f"3DMM-only, {m}")
    axes[0].axhline(tex[steps[-1]]["psnr_unwrap_diffuse"], color="tab:orange", ls=":", lw=1,
                    label="unwrap over 3DMM albedo")
    run_csv = os.path.join(out, "tex_run_G_seed0", "eval.csv")
    run = evals(run_csv) if os.path.exists(run_csv) else {}
    if run:  # step 4: the net trained and validated on photos through the run pipeline (texgen run-dataset)
        rs = list(run)
        axes[0].plot(rs, [run[s]["psnr_diffuse"] for s in rs], "s-", ms=3, color="tab:red",
                     label="UV net on run-dataset, diffuse (val photos)")
        axes[0].axhline(run[rs[-1]]["psnr_unwrap_diffuse"], color="tab:red", ls=":", lw=1,
                        label="photo's unwrap over 3DMM albedo")
    axes[0].set_xlabel("step")
    axes[0].set_ylabel("held-out PSNR, UV layout (dB)")
    axes[0].set_title("texture net (--profile cpu), validation subjects", fontsize=9)
    axes[0].set_ylim(bottom=8)  # room for the legend below the curves
    axes[0].legend(fontsize=6, loc="lower right", ncol=2)
    for m, color in (("diffuse", "tab:orange"), ("roughness", "tab:green"), ("specular", "tab:purple")):
        path = os.path.join(out, f"up_{m}", "eval.csv")
        if not os.path.exists(path):
            continue
        up = evals(path)
        s = list(up)
        axes[1].plot(s, [up[k]["psnr_srgan"] for k in s], "o-", ms=3, color=color, label=f"SRGAN, {m}")
        axes[1].axhline(up[s[-1]]["psnr_bicubic"], color=color, ls="--", lw=1, label=f"bicubic, {m}")
    axes[1].set_xlabel("step")
    axes[1].set_ylabel("held-out PSNR ×4 (dB)")
    axes[1].set_title("SRGAN ×4 (--profile cpu), validation subjects' true maps", fontsize=9)
    axes[1].legend(fontsize=6, loc="lower right")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "curves_texture.png"))


if __name__ == "__main__":
    main()
