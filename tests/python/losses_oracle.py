#!/usr/bin/python3
"""Oracle for training/losses_test.cc: the same figures from independent code (scikit-image, torchvision).

Images are raw little-endian float64 files of shape [N, C, H, W]. Prints one JSON object.

usage:
  losses_oracle.py ssim A.bin B.bin N C H W DATA_RANGE
      per image: skimage.metrics.structural_similarity(gaussian_weights=True, sigma=1.5,
      use_sample_covariance=False, data_range, channel_axis) and peak_signal_noise_ratio(data_range)
  losses_oracle.py lpips-vgg16-random A.bin B.bin N C H W SEED
      per image: LPIPS with torchvision's VGG16 `features` layout (make_layers of configuration D) initialised as docs/training.md states (Kaiming normal,
      fan_out, ReLU gain, drawn layer by layer from one torch.Generator seeded SEED; biases 0), taps relu1_2..relu5_3,
      ImageNet normalisation of [0, 1] input, unit-normalised channels, linear weights 1/C ("lin-free")
"""
import json
import math
import sys

import numpy as np


def read(path, shape):
    return np.fromfile(path, dtype="<f8").reshape(shape)


def ssim(a, b, data_range):
    from skimage.metrics import peak_signal_noise_ratio, structural_similarity

    out = {"ssim": [], "psnr": []}
    for x, y in zip(a, b):
        out["ssim"].append(float(structural_similarity(
            x, y, gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=data_range,
            channel_axis=0)))
        out["psnr"].append(float(peak_signal_noise_ratio(x, y, data_range=data_range)))
    return out


def lpips_vgg16_random(a, b, seed):
    import torch
    import torchvision

    features = torchvision.models.vgg.make_layers(torchvision.models.vgg.cfgs["D"])[:30].double()
    generator = torch.Generator().manual_seed(seed)
    with torch.no_grad():
        for layer in features:
            if isinstance(layer, torch.nn.Conv2d):
                fan_out = layer.out_channels * layer.kernel_size[0] * layer.kernel_size[1]
                w = torch.empty(layer.weight.shape, dtype=torch.float32)
                w.normal_(0, math.sqrt(2.0 / fan_out), generator=generator)
                layer.weight.copy_(w)
                layer.bias.zero_()
    mean = torch.tensor([0.485, 0.456, 0.406], dtype=torch.float64).view(1, 3, 1, 1)
    std = torch.tensor([0.229, 0.224, 0.225], dtype=torch.float64).view(1, 3, 1, 1)

    def taps(x):
        x = (torch.from_numpy(x) - mean) / std
        out = []
        for i, layer in enumerate(features):
            x = layer(x)
            if i in (3, 8, 15, 22, 29):
                out.append(x)
        return out

    with torch.no_grad():
        total = torch.zeros(a.shape[0], dtype=torch.float64)
        for fa, fb in zip(taps(a), taps(b)):
            na = fa / torch.sqrt((fa ** 2).sum(1, keepdim=True) + 1e-10)
            nb = fb / torch.sqrt((fb ** 2).sum(1, keepdim=True) + 1e-10)
            total += ((na - nb) ** 2).mean(1).mean((1, 2))  # weights 1/C: the channel mean
    return {"lpips": total.tolist(), "conv1_1_weight_sum": float(features[0].weight.sum())}


def main(argv):
    command, path_a, path_b = argv[1:4]
    shape = tuple(int(v) for v in argv[4:8])
    a, b = read(path_a, shape), read(path_b, shape)
    if command == "ssim":
        result = ssim(a, b, float(argv[8]))
    elif command == "lpips-vgg16-random":
        result = lpips_vgg16_random(a, b, int(argv[8]))
    else:
        raise SystemExit(f"unknown command {command}")
    print(json.dumps(result))


if __name__ == "__main__":
    main(sys.argv)
