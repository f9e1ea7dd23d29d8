#!/usr/bin/python3
"""The PyTorch-eager half of bench/step_vs_pytorch.sh: the step train_step_bench times through our Trainer, written
in plain torch.nn / torch.optim with Debian's python3-torch (run it with /usr/bin/python3), the nets from
tests/python/reference_nets.py (the same layouts as ours, checked by tests/python/torchvision_oracle.py):
  F  ReconNet (a ResNet-18 of --width, zero-initialised heads for --coeffs and γ) on [B, 3, S, S], the mean squared
     error to fixed random coefficients, Adam 1e-4.
  G  the pix2pix U-Net of ngf --width (num_downs = max(5, log2 S)), residual (output = input + U-Net(2·input − 1),
     last layer zeroed), and the PatchGAN of --ndf / --n-layers: D's step (vanilla GAN on the pairs [input, image]),
     then G's (L1 ×100 + GAN, D frozen); Adam 2e-4, β 0.5 / 0.999. No LPIPS.
Each optimizer's phase is the Trainer's (training/trainer.cc): zero the gradients, the losses, their values read
and checked for NaN, backward of their sum, Adam's step. A step's time is the time between the starts of two
consecutive steps, in wall time ("ms") and the process's CPU time ("cpu_ms"); one JSON line: the parameters per module and the median (the upper one of an even count, as
bench/bench_util.h) of --steps steps after --warmup.
"""
import argparse
import json
import math
import os
import sys
import time

import torch
import torch.nn.functional as F

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "python"))
from reference_nets import PatchGAN, ReconNet, UnetGenerator, parameter_count  # noqa: E402


def phase(optimizer, losses_of):
    optimizer.zero_grad()
    losses = losses_of()
    values = torch.cat([v.detach().double().reshape(1) for v in losses.values()]).tolist()
    if not all(math.isfinite(x) for x in values):
        sys.exit(f"step_vs_pytorch.py: a loss is not finite: {dict(zip(losses, values))}")
    total = None
    for v in losses.values():
        total = v.float() if total is None else total + v.float()
    total.backward()
    optimizer.step()


class FStep:
    def __init__(self, a):
        self.net = ReconNet(18, a.width, *a.coeffs)
        self.adam = torch.optim.Adam(self.net.parameters(), lr=1e-4)
        outputs = sum(a.coeffs) + 6 + 27
        self.image, self.target = torch.rand(a.batch, 3, a.size, a.size), torch.randn(a.batch, outputs)

    def modules(self):
        return {"F": self.net}

    def step(self):
        phase(self.adam, lambda: {"mse": F.mse_loss(self.net(self.image), self.target)})


def bce(prediction, real):
    return F.binary_cross_entropy_with_logits(prediction, torch.full_like(prediction, 1.0 if real else 0.0))


class GStep:
    def __init__(self, a):
        self.G = UnetGenerator(ngf=a.width, num_downs=max(5, round(math.log2(a.size))))
        with torch.no_grad():  # residual G starts as the identity (bareskinnet.cc, zero_last_layer)
            for p in self.G.model.model[3].parameters():
                p.zero_()
        self.D = PatchGAN(ndf=a.ndf, n_layers=a.n_layers)
        self.adam_d = torch.optim.Adam(self.D.parameters(), lr=2e-4, betas=(0.5, 0.999))
        self.adam_g = torch.optim.Adam(self.G.parameters(), lr=2e-4, betas=(0.5, 0.999))
        self.makeup, self.before = (torch.rand(a.batch, 3, a.size, a.size) for _ in range(2))

    def modules(self):
        return {"D": self.D, "G": self.G}

    def discriminate(self, image):
        return self.D(torch.cat([self.makeup * 2 - 1, image * 2 - 1], 1))

    def step(self):
        out = self.makeup + self.G(self.makeup * 2 - 1)
        phase(self.adam_d, lambda: {"gan": 0.5 * (bce(self.discriminate(self.before), True) +
                                                  bce(self.discriminate(out.detach()), False))})

        def g_losses():
            for p in self.D.parameters():
                p.requires_grad_(False)
            losses = {"gan": bce(self.discriminate(out), True), "l1": 100 * (out - self.before).abs().mean()}
            for p in self.D.parameters():
                p.requires_grad_(True)
            return losses

        phase(self.adam_g, g_losses)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--net", choices=["F", "G"], default="F")
    p.add_argument("--width", type=int, default=8, help="F: the ResNet's width; G: the U-Net's ngf")
    p.add_argument("--size", type=int, default=64)
    p.add_argument("--batch", type=int, default=8)
    p.add_argument("--steps", type=int, default=20)
    p.add_argument("--warmup", type=int, default=5)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--ndf", type=int, default=16)
    p.add_argument("--n-layers", type=int, default=2)
    p.add_argument("--coeffs", type=lambda s: [int(x) for x in s.split(",")], default=[80, 64, 80])
    a = p.parse_args()
    torch.set_num_threads(a.threads)
    torch.manual_seed(1)
    task = FStep(a) if a.net == "F" else GStep(a)
    for m in task.modules().values():
        m.train()
    starts, cpu_starts = [], []
    for _ in range(a.warmup + a.steps + 1):
        starts.append(time.perf_counter())
        cpu_starts.append(time.process_time())
        task.step()
    ms = [1000 * (t1 - t0) for t0, t1 in zip(starts, starts[1:])][a.warmup:]
    cpu_ms = [1000 * (t1 - t0) for t0, t1 in zip(cpu_starts, cpu_starts[1:])][a.warmup:]
    print(json.dumps({"side": "pytorch", "net": a.net, "width": a.width, "size": a.size, "batch": a.batch,
                      "threads": torch.get_num_threads(),
                      "params": {k: parameter_count(m) for k, m in sorted(task.modules().items())},
                      "ms": ms, "median_ms": sorted(ms)[len(ms) // 2],
                      "cpu_ms": cpu_ms, "median_cpu_ms": sorted(cpu_ms)[len(cpu_ms) // 2],
                      "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY", ""), "torch": torch.__version__}))


if __name__ == "__main__":
    main()
