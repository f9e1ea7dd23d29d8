#!/usr/bin/python3
"""Independent oracle for the network zoo (training/nets): our exported state dicts must load, strictly and by name,
into the reference networks built by Python torch (Debian's python3-torch / torchvision, not our code), and the
reference networks must give our outputs on the same input.

- ResNet-18/34/50: torchvision.models themselves.
- pix2pix U-Net and PatchGAN, pix2pixHD global generator, local enhancer and multiscale discriminator, BasicSR's
  MSRResNet and VGG-style discriminator: rebuilt below from torch.nn modules in the reference code's module layout
  (the same nesting, the same Sequential indices), so the state dict keys are the reference's.

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
import torch.nn as nn
import torch.nn.functional as F
import torchvision

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from safetensors_oracle import read_safetensors  # noqa: E402

TOLERANCE = 1e-5


# ---- pix2pix (Isola et al.) -------------------------------------------------------------------------------------

def norm_layer(kind, channels, affine_instance=False):
    if kind == "batch":
        return nn.BatchNorm2d(channels)
    if kind == "instance":
        return nn.InstanceNorm2d(channels, affine=affine_instance)
    return nn.Identity()


class UnetBlock(nn.Module):
    def __init__(self, outer, inner, input_nc=None, sub=None, outermost=False, innermost=False, norm="batch",
                 dropout=False):
        super().__init__()
        self.outermost = outermost
        bias = norm != "batch"
        input_nc = outer if input_nc is None else input_nc
        down = nn.Conv2d(input_nc, inner, 4, 2, 1, bias=bias)
        if outermost:
            layers = [down, sub, nn.ReLU(True), nn.ConvTranspose2d(inner * 2, outer, 4, 2, 1), nn.Tanh()]
        elif innermost:
            layers = [nn.LeakyReLU(0.2, True), down, nn.ReLU(True),
                      nn.ConvTranspose2d(inner, outer, 4, 2, 1, bias=bias), norm_layer(norm, outer)]
        else:
            layers = [nn.LeakyReLU(0.2, True), down, norm_layer(norm, inner), sub, nn.ReLU(True),
                      nn.ConvTranspose2d(inner * 2, outer, 4, 2, 1, bias=bias), norm_layer(norm, outer)]
            layers += [nn.Dropout(0.5)] if dropout else []
        self.model = nn.Sequential(*layers)

    def forward(self, x):
        return self.model(x) if self.outermost else torch.cat([x, self.model(x)], 1)


class UnetGenerator(nn.Module):
    def __init__(self, in_channels=3, out_channels=3, ngf=64, num_downs=8, norm="batch", dropout=True,
                 upsample="transpose"):
        super().__init__()
        assert upsample == "transpose", "the reference has transposed convolutions only"
        block = UnetBlock(ngf * 8, ngf * 8, innermost=True, norm=norm)
        for _ in range(num_downs - 5):
            block = UnetBlock(ngf * 8, ngf * 8, sub=block, norm=norm, dropout=dropout)
        for k in (4, 2, 1):
            block = UnetBlock(ngf * k, ngf * k * 2, sub=block, norm=norm)
        self.model = UnetBlock(out_channels, ngf, input_nc=in_channels, sub=block, outermost=True, norm=norm)

    def forward(self, x):
        return self.model(x)


class PatchGAN(nn.Module):
    def __init__(self, in_channels=6, ndf=64, n_layers=3, norm="batch"):
        super().__init__()
        bias = norm != "batch"
        seq, mult = [nn.Conv2d(in_channels, ndf, 4, 2, 1), nn.LeakyReLU(0.2, True)], 1
        for n in range(1, n_layers + 1):
            prev, mult = mult, min(2 ** n, 8)
            seq += [nn.Conv2d(ndf * prev, ndf * mult, 4, 2 if n < n_layers else 1, 1, bias=bias),
                    norm_layer(norm, ndf * mult), nn.LeakyReLU(0.2, True)]
        self.model = nn.Sequential(*seq, nn.Conv2d(ndf * mult, 1, 4, 1, 1))

    def forward(self, x):
        return self.model(x)


# ---- pix2pixHD (Wang et al.) ------------------------------------------------------------------------------------

class HDResnetBlock(nn.Module):
    def __init__(self, dim, norm):
        super().__init__()
        self.conv_block = nn.Sequential(nn.ReflectionPad2d(1), nn.Conv2d(dim, dim, 3), norm_layer(norm, dim),
                                        nn.ReLU(True), nn.ReflectionPad2d(1), nn.Conv2d(dim, dim, 3),
                                        norm_layer(norm, dim))

    def forward(self, x):
        return x + self.conv_block(x)


def hd_global_layers(inc, outc, ngf, n_down, n_blocks, norm, head=True):
    m = [nn.ReflectionPad2d(3), nn.Conv2d(inc, ngf, 7), norm_layer(norm, ngf), nn.ReLU(True)]
    for i in range(n_down):
        c = ngf * 2 ** i
        m += [nn.Conv2d(c, c * 2, 3, 2, 1), norm_layer(norm, c * 2), nn.ReLU(True)]
    m += [HDResnetBlock(ngf * 2 ** n_down, norm) for _ in range(n_blocks)]
    for i in range(n_down):
        c = ngf * 2 ** (n_down - i)
        m += [nn.ConvTranspose2d(c, c // 2, 3, 2, 1, output_padding=1), norm_layer(norm, c // 2), nn.ReLU(True)]
    if head:
        m += [nn.ReflectionPad2d(3), nn.Conv2d(ngf, outc, 7), nn.Tanh()]
    return m


class GlobalGenerator(nn.Module):
    def __init__(self, in_channels=3, out_channels=3, ngf=64, n_downsampling=4, n_blocks=9, norm="instance"):
        super().__init__()
        self.model = nn.Sequential(*hd_global_layers(in_channels, out_channels, ngf, n_downsampling, n_blocks, norm))

    def forward(self, x):
        return self.model(x)


def hd_downsample(x):
    return F.avg_pool2d(x, 3, stride=2, padding=1, count_include_pad=False)


class LocalEnhancer(nn.Module):
    def __init__(self, in_channels=3, out_channels=3, ngf=32, n_downsample_global=4, n_blocks_global=9,
                 n_local_enhancers=1, n_blocks_local=3, norm="instance"):
        super().__init__()
        self.n = n_local_enhancers
        self.model = nn.Sequential(*hd_global_layers(in_channels, out_channels, ngf * 2 ** n_local_enhancers,
                                                     n_downsample_global, n_blocks_global, norm, head=False))
        for n in range(1, n_local_enhancers + 1):
            c = ngf * 2 ** (n_local_enhancers - n)
            front = [nn.ReflectionPad2d(3), nn.Conv2d(in_channels, c, 7), norm_layer(norm, c), nn.ReLU(True),
                     nn.Conv2d(c, c * 2, 3, 2, 1), norm_layer(norm, c * 2), nn.ReLU(True)]
            back = [HDResnetBlock(c * 2, norm) for _ in range(n_blocks_local)]
            back += [nn.ConvTranspose2d(c * 2, c, 3, 2, 1, output_padding=1), norm_layer(norm, c), nn.ReLU(True)]
            if n == n_local_enhancers:
                back += [nn.ReflectionPad2d(3), nn.Conv2d(ngf, out_channels, 7), nn.Tanh()]
            setattr(self, f"model{n}_1", nn.Sequential(*front))
            setattr(self, f"model{n}_2", nn.Sequential(*back))

    def forward(self, x):
        pyramid = [x]
        for _ in range(self.n):
            pyramid.append(hd_downsample(pyramid[-1]))
        out = self.model(pyramid[-1])
        for n in range(1, self.n + 1):
            out = getattr(self, f"model{n}_2")(getattr(self, f"model{n}_1")(pyramid[self.n - n]) + out)
        return out


class MultiscaleDiscriminator(nn.Module):
    def __init__(self, in_channels=6, ndf=64, n_layers=3, norm="instance", num_D=2, get_interm_feat=True,
                 use_sigmoid=False):
        super().__init__()
        self.num_D, self.interm = num_D, get_interm_feat
        for d in range(num_D):
            groups, nf = [[nn.Conv2d(in_channels, ndf, 4, 2, 2), nn.LeakyReLU(0.2, True)]], ndf
            for n in range(1, n_layers + 1):
                prev, nf = nf, min(nf * 2, 512)
                groups += [[nn.Conv2d(prev, nf, 4, 2 if n < n_layers else 1, 2), norm_layer(norm, nf),
                            nn.LeakyReLU(0.2, True)]]
            groups += [[nn.Conv2d(nf, 1, 4, 1, 2)]] + ([[nn.Sigmoid()]] if use_sigmoid else [])
            self.n_groups = len(groups)
            if get_interm_feat:
                for j, g in enumerate(groups):
                    setattr(self, f"scale{d}_layer{j}", nn.Sequential(*g))
            else:
                setattr(self, f"layer{d}", nn.Sequential(*[m for g in groups for m in g]))

    def forward(self, x):
        result = []
        for i in range(self.num_D):
            d = self.num_D - 1 - i
            if self.interm:
                feats, h = [], x
                for j in range(self.n_groups):
                    h = getattr(self, f"scale{d}_layer{j}")(h)
                    feats.append(h)
            else:
                feats = [getattr(self, f"layer{d}")(x)]
            result.append(feats)
            if i != self.num_D - 1:
                x = hd_downsample(x)
        return result


# ---- BasicSR ----------------------------------------------------------------------------------------------------

class ResidualBlockNoBN(nn.Module):
    def __init__(self, nf):
        super().__init__()
        self.conv1, self.conv2 = nn.Conv2d(nf, nf, 3, 1, 1), nn.Conv2d(nf, nf, 3, 1, 1)

    def forward(self, x):
        return x + self.conv2(F.relu(self.conv1(x)))


class MSRResNet(nn.Module):
    def __init__(self, num_in_ch=3, num_out_ch=3, num_feat=64, num_block=16, upscale=4):
        super().__init__()
        self.upscale = upscale
        self.conv_first = nn.Conv2d(num_in_ch, num_feat, 3, 1, 1)
        self.body = nn.Sequential(*[ResidualBlockNoBN(num_feat) for _ in range(num_block)])
        r = 2 if upscale == 4 else upscale
        self.upconv1 = nn.Conv2d(num_feat, num_feat * r * r, 3, 1, 1)
        if upscale == 4:
            self.upconv2 = nn.Conv2d(num_feat, num_feat * 4, 3, 1, 1)
        self.conv_hr = nn.Conv2d(num_feat, num_feat, 3, 1, 1)
        self.conv_last = nn.Conv2d(num_feat, num_out_ch, 3, 1, 1)

    def forward(self, x):
        lrelu = lambda t: F.leaky_relu(t, 0.1)  # noqa: E731
        out = self.body(lrelu(self.conv_first(x)))
        out = lrelu(F.pixel_shuffle(self.upconv1(out), 2 if self.upscale == 4 else self.upscale))
        if self.upscale == 4:
            out = lrelu(F.pixel_shuffle(self.upconv2(out), 2))
        out = self.conv_last(lrelu(self.conv_hr(out)))
        return out + F.interpolate(x, scale_factor=self.upscale, mode="bilinear", align_corners=False)


class VGGStyleDiscriminator(nn.Module):
    def __init__(self, num_in_ch=3, num_feat=64, input_size=128):
        super().__init__()
        self.names = []
        self.conv0_0 = nn.Conv2d(num_in_ch, num_feat, 3, 1, 1)
        c_in = num_feat
        for k in range(5 if input_size == 128 else 6):
            c = num_feat * min(2 ** k, 8)
            for s in ((1,) if k == 0 else (0, 1)):
                conv = nn.Conv2d(c_in, c, 3, 1, 1, bias=False) if s == 0 else nn.Conv2d(c, c, 4, 2, 1, bias=False)
                setattr(self, f"conv{k}_{s}", conv)
                setattr(self, f"bn{k}_{s}", nn.BatchNorm2d(c))
                self.names.append(f"{k}_{s}")
                c_in = c
        self.linear1, self.linear2 = nn.Linear(c_in * 16, 100), nn.Linear(100, 1)

    def forward(self, x):
        h = F.leaky_relu(self.conv0_0(x), 0.2)
        for n in self.names:
            h = F.leaky_relu(getattr(self, f"bn{n}")(getattr(self, f"conv{n}")(h)), 0.2)
        return self.linear2(F.leaky_relu(self.linear1(h.flatten(1)), 0.2))


# ---- the check --------------------------------------------------------------------------------------------------

def reference(model, options):
    tv = torchvision.models
    if model in ("resnet18", "resnet50"):
        depth = options.get("depth", 18 if model == "resnet18" else 50)
        assert options.get("width", 64) == 64 and options.get("in_channels", 3) == 3, "torchvision has no such option"
        classes = options.get("num_classes", 1000)
        net = {18: tv.resnet18, 34: tv.resnet34, 50: tv.resnet50}[depth](num_classes=max(classes, 1))
        if classes == 0:
            net.fc = nn.Identity()
        return net
    return {"unet256": UnetGenerator, "patchgan": PatchGAN, "pix2pixhd_global": GlobalGenerator,
            "pix2pixhd_local": LocalEnhancer, "pix2pixhd_multiscale_d": MultiscaleDiscriminator,
            "msrresnet": MSRResNet, "srgan_d": VGGStyleDiscriminator}[model](**options)


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
