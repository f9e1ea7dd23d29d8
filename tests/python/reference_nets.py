#!/usr/bin/python3
"""The toolkit's networks rebuilt by Python torch (Debian's python3-torch / torchvision, not our code), in the
reference code's module layout (the same nesting, the same Sequential indices), so that our state dicts load into
them by name. One copy, shared by the zoo's oracle (torchvision_oracle.py) and the training-step benchmark
(bench/step_vs_pytorch.py).

- ResNet-18/34/50: torchvision.models themselves; at another width than torchvision's 64 (our `width` option),
  torchvision's own ResNet class, blocks and layer builder with the channel counts scaled (TorchvisionResNet).
- pix2pix U-Net and PatchGAN, pix2pixHD global generator, local enhancer and multiscale discriminator, BasicSR's
  MSRResNet and VGG-style discriminator: rebuilt below from torch.nn modules.
- ReconNet: recon/recon.h's F / E (a headless ResNet and one zero-initialised linear head per coefficient group).
"""
import torch
import torch.nn as nn
import torch.nn.functional as F
import torchvision
from torchvision.models.resnet import BasicBlock, Bottleneck, ResNet

# ---- ResNet (torchvision) ---------------------------------------------------------------------------------------

RESNET_BLOCKS = {18: (BasicBlock, [2, 2, 2, 2]), 34: (BasicBlock, [3, 4, 6, 3]), 50: (Bottleneck, [3, 4, 6, 3])}


class TorchvisionResNet(ResNet):
    """torchvision's ResNet with conv1 and layer1 of `width` channels (layer k: width·2^(k-1)) instead of 64 and
    `in_channels` inputs: torchvision's __init__ with those numbers, its _make_layer, blocks and forward. At width 64
    it is torchvision.models.resnetXX. num_classes 0: no head (the pooled features)."""

    def __init__(self, depth=18, width=64, num_classes=1000, in_channels=3):
        nn.Module.__init__(self)
        block, layers = RESNET_BLOCKS[depth]
        self._norm_layer, self.inplanes, self.dilation, self.groups, self.base_width = nn.BatchNorm2d, width, 1, 1, 64
        self.conv1 = nn.Conv2d(in_channels, width, kernel_size=7, stride=2, padding=3, bias=False)
        self.bn1, self.relu = nn.BatchNorm2d(width), nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(kernel_size=3, stride=2, padding=1)
        self.layer1 = self._make_layer(block, width, layers[0])
        self.layer2 = self._make_layer(block, width * 2, layers[1], stride=2)
        self.layer3 = self._make_layer(block, width * 4, layers[2], stride=2)
        self.layer4 = self._make_layer(block, width * 8, layers[3], stride=2)
        self.avgpool = nn.AdaptiveAvgPool2d((1, 1))
        self.features = width * 8 * block.expansion
        self.fc = nn.Linear(self.features, num_classes) if num_classes else nn.Identity()
        for m in self.modules():  # torchvision's initialisation
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            elif isinstance(m, nn.BatchNorm2d):
                nn.init.constant_(m.weight, 1)
                nn.init.constant_(m.bias, 0)


def resnet(depth=18, width=64, num_classes=1000, in_channels=3):
    """torchvision.models.resnetXX where torchvision has it (width 64, 3 inputs), else TorchvisionResNet."""
    if width == 64 and in_channels == 3:
        net = {18: torchvision.models.resnet18, 34: torchvision.models.resnet34,
               50: torchvision.models.resnet50}[depth](num_classes=max(num_classes, 1))
        if num_classes == 0:
            net.fc = nn.Identity()
        return net
    return TorchvisionResNet(depth, width, num_classes, in_channels)


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


# ---- F / E (recon/recon.h) --------------------------------------------------------------------------------------

class ReconNet(nn.Module):
    """A headless ResNet, its pooled features into one zero-initialised linear head per group: α (k_id), β (k_exp),
    δ (k_app), rotation 3, translation 3 (× translation_scale), γ 27 (+ 0.8 on each channel's first coefficient)."""

    def __init__(self, depth=18, width=64, k_id=80, k_exp=64, k_app=80, gamma=True, translation_scale=10.0):
        super().__init__()
        self.backbone = resnet(depth, width, num_classes=0)
        c = width * 8 * (4 if depth == 50 else 1)
        sizes = {"alpha": k_id, "beta": k_exp, "delta": k_app, "rotation": 3, "translation": 3}
        if gamma:
            sizes["gamma"] = 27
        self.heads = list(sizes)
        for name, k in sizes.items():
            head = nn.Linear(c, k)
            nn.init.zeros_(head.weight)
            nn.init.zeros_(head.bias)
            setattr(self, name, head)
        self.translation_scale = translation_scale
        ambient = torch.zeros(27)
        ambient[0::9] = 0.8
        self.register_buffer("ambient", ambient, persistent=False)

    def forward(self, image):
        f = self.backbone(image)
        out = [getattr(self, name)(f) for name in self.heads if name != "gamma"]
        out[4] = out[4] * self.translation_scale
        if "gamma" in self.heads:
            out.append(self.gamma(f) + self.ambient)
        return torch.cat(out, 1)


# ---- by the zoo's names -----------------------------------------------------------------------------------------

def reference(model, options):
    """The reference network of a zoo entry (training/nets/zoo.cc) with our options."""
    if model in ("resnet18", "resnet50"):
        return resnet(options.get("depth", 18 if model == "resnet18" else 50), options.get("width", 64),
                      options.get("num_classes", 1000), options.get("in_channels", 3))
    return {"unet256": UnetGenerator, "patchgan": PatchGAN, "pix2pixhd_global": GlobalGenerator,
            "pix2pixhd_local": LocalEnhancer, "pix2pixhd_multiscale_d": MultiscaleDiscriminator,
            "msrresnet": MSRResNet, "srgan_d": VGGStyleDiscriminator}[model](**options)


def parameter_count(net):
    return sum(p.numel() for p in net.parameters())
