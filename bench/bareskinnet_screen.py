"""Fast screen of BareSkinNet's UV stability: G alone, no fit and no unwrap.

The stability bench (bench/bareskinnet_stability.sh) runs `demakeup --aligned` on every condition (G -> F -> unwrap
into the UV, about 45 CPU-s per subject). The conditions of a subject there are frontal, without expression and
occluders, so the aligned images are pixel-aligned and G's output can be compared pixel by pixel: this script runs
G (or its moving average) of a run the way `demakeup` does (area resize to G's size, G, bilinear back to 256², clamp,
8-bit) through the pix2pix U-Net of tests/python/torchvision_oracle.py with the checkpoint's weights, and prints per
subject the per-pixel standard deviation over the conditions on the face (the bare truth's non-black pixels in every
condition) and the spread of the face's mean level. On 14 runs it read 0.8-1.4 below the bench's UV figure in the
same order (bench/BENCHMARKS.md, "BareSkinNet").
  /usr/bin/python3 bench/bareskinnet_screen.py RUN STAB/inputs [raw]
STAB/inputs: the makeup/ and bare/ folders bareskinnet_stability.sh extracts; raw: G, not G_ema.
"""
import glob, json, os, struct, sys

import numpy as np
import torch
import torch.nn.functional as Fn
from skimage import io

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "python"))
from torchvision_oracle import UnetGenerator  # noqa: E402


def read_g(path):
    """The module.G* tensors of a checkpoint and its metadata."""
    with open(path, "rb") as f:
        n = struct.unpack("<Q", f.read(8))[0]
        header = json.loads(f.read(n))
        base = 8 + n
        dtypes = {"F32": np.float32, "F64": np.float64, "I64": np.int64}
        out = {}
        for k, v in header.items():
            if k == "__metadata__" or not k.startswith("module.G"):
                continue
            f.seek(base + v["data_offsets"][0])
            b = f.read(v["data_offsets"][1] - v["data_offsets"][0])
            out[k] = torch.from_numpy(np.frombuffer(b, dtypes[v["dtype"]]).reshape(v["shape"]).copy())
    return out, json.loads(header["__metadata__"]["bareskin.checkpoint"])


def main():
    run, inputs = sys.argv[1], sys.argv[2]
    raw = len(sys.argv) > 3 and sys.argv[3] == "raw"
    torch.set_num_threads(1)
    ck = os.path.join(run, "stage2", "checkpoint.safetensors")
    if not os.path.exists(ck):
        ck = os.path.join(run, "stage1", "checkpoint.safetensors")
    w, meta = read_g(ck)
    task = meta["config"]["task"]
    size, g = task["size"], dict(task["g"])
    head = task.get("head", "residual" if task.get("residual", False) else "image")
    net = UnetGenerator(out_channels=6 if head == "affine" else 3, ngf=g.get("ngf", 64), num_downs=g.get("num_downs", max(5, int(round(np.log2(size))))),
                        norm=g.get("norm", "batch"), dropout=g.get("dropout", True))
    prefix = "module.G_ema.G." if not raw and any(k.startswith("module.G_ema.") for k in w) else "module.G."
    net.load_state_dict({k[len(prefix):]: v for k, v in w.items() if k.startswith(prefix) and not k.endswith("updates")})
    net.eval()
    rows = []
    for d in sorted(glob.glob(os.path.join(inputs, "makeup", "*"))):
        s = os.path.basename(d)
        keys = sorted(os.path.basename(p)[:-4] for p in glob.glob(os.path.join(d, "*.png")))
        x = np.stack([io.imread(os.path.join(d, k + ".png"))[..., :3] for k in keys]).astype(np.float32) / 255
        x = torch.from_numpy(x).permute(0, 3, 1, 2)
        face = np.logical_and.reduce(
            [io.imread(os.path.join(inputs, "bare", s, k + ".png"))[..., :3].max(-1) > 8 for k in keys])
        with torch.no_grad():
            xs = Fn.interpolate(x, size=(size, size), mode="area")
            y = net(xs * 2 - 1)
            y = {"residual": lambda: xs + y, "affine": lambda: xs * y[:, :3].exp() + y[:, 3:],
                 "image": lambda: (y + 1) * 0.5}[head]()
            y = Fn.interpolate(y, size=(256, 256), mode="bilinear", align_corners=False).clamp(0, 1)
        y8 = np.round(y.permute(0, 2, 3, 1).numpy() * 255)
        rows.append((s, y8.std(0).mean(-1)[face].mean(), y8[:, face].mean(1).std(0).mean()))
    print(f"{run} ({'G' if prefix == 'module.G.' else 'G_ema'}): per-pixel std " +
          " ".join(f"{s} {a:.2f}" for s, a, _ in rows) + f", mean {np.mean([r[1] for r in rows]):.2f}; "
          "level std " + " ".join(f"{b:.2f}" for _, _, b in rows))


if __name__ == "__main__":
    main()
