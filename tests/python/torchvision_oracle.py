#!/usr/bin/python3
"""Independent oracle for the network zoo (training/nets): our exported state dicts must load, strictly and by name,
into the reference networks built by Python torch (Debian's python3-torch / torchvision, not our code; the networks
are in reference_nets.py), and the reference networks must give our outputs on the same input.

usage: torchvision_oracle.py EXPORTER     (runs `EXPORTER DIR`, then checks every case it wrote)
       torchvision_oracle.py --counts     (parameter counts of the reference layouts at the paper's sizes)
"""
import json
import os
import subprocess
import sys
import tempfile

import numpy as np
import torch
import torchvision

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from reference_nets import (GlobalGenerator, LocalEnhancer, MSRResNet, MultiscaleDiscriminator, PatchGAN,  # noqa: E402
                            UnetGenerator, VGGStyleDiscriminator, reference)
from safetensors_oracle import read_safetensors  # noqa: E402

TOLERANCE = 1e-5


def flat_output(model, out):
    if model == "pix2pixhd_multiscale_d":
        return torch.cat([f.flatten() for scale in out for f in scale])
    return out


def check_case(folder, case):
    meta, weights = read_safetensors(f"{folder}/{case}.safetensors")
    _, io = read_safetensors(f"{folder}/{case}_io.safetensors")
    model, options = meta["model"], json.loads(meta["options"])
    net = reference(model, options)
    expected = net.state_dict()
    assert set(weights) == set(expected), (f"{case}: names differ; only ours: {sorted(set(weights) - set(expected))[:5]}"
                                           f" only the reference's: {sorted(set(expected) - set(weights))[:5]}")
    for name, t in expected.items():
        assert tuple(weights[name].shape) == tuple(t.shape), f"{case}: {name} {weights[name].shape} vs {tuple(t.shape)}"
    net.load_state_dict({k: torch.from_numpy(np.array(v)) for k, v in weights.items()}, strict=True)
    net.eval()
    with torch.no_grad():
        out = flat_output(model, net(torch.from_numpy(np.array(io["input"])))).numpy()
    ours = io["output"]
    assert out.shape == ours.shape, f"{case}: output shape {ours.shape} vs {out.shape}"
    diff = float(np.abs(out - ours).max())
    count = sum(int(np.prod(t.shape)) for t in net.parameters())
    print(f"{case}: {len(expected)} tensors by name, {count:,} parameters, output {list(out.shape)} "
          f"|max| {np.abs(out).max():.3g}, max abs diff {diff:.2e}")
    assert diff <= TOLERANCE, f"{case}: max abs diff {diff} > {TOLERANCE}"


def print_counts():
    nets = {"resnet18": torchvision.models.resnet18(), "resnet50": torchvision.models.resnet50(),
            "unet256": UnetGenerator(), "patchgan": PatchGAN(), "pix2pixhd_global": GlobalGenerator(),
            "pix2pixhd_local": LocalEnhancer(), "pix2pixhd_multiscale_d": MultiscaleDiscriminator(),
            "msrresnet": MSRResNet(), "srgan_d": VGGStyleDiscriminator()}
    for name, net in nets.items():
        print(name, sum(p.numel() for p in net.parameters()))


def main():
    if sys.argv[1:] == ["--counts"]:
        return print_counts()
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    torch.set_num_threads(2)
    with tempfile.TemporaryDirectory() as folder:
        subprocess.run([sys.argv[1], folder], check=True)
        cases = sorted(f[:-len(".safetensors")] for f in os.listdir(folder)
                       if f.endswith(".safetensors") and not f.endswith("_io.safetensors"))
        assert len(cases) >= 3, cases
        for case in cases:
            check_case(folder, case)
    print(f"{len(cases)} passed, 0 failed")


if __name__ == "__main__":
    main()
