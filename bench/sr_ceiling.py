#!/usr/bin/env python3
"""How much can any ×4 upscaler gain over bicubic on a map? A band-limit oracle, no network involved.

The upscalers see the true map area-downsampled by the factor (what `texgen make-dataset` gives them). What survives
the downsampling is the map's content below the low-resolution Nyquist frequency; what lies above it (pores a
fraction of a low-resolution pixel wide, their exact position inside it) is gone. For each map this prints:

  bicubic      the low-resolution map bicubically upsampled (PIL), against the truth
  band oracle  the truth with every frequency the low-resolution map can carry kept exactly and every frequency
               above it set to zero (FFT): the best an upscaler does that restores the band perfectly and invents
               nothing beyond it

An upscaler can beat "band oracle" only by predicting content above the band from the content below it (edges,
the shape of a pore it can place); a gap of "band oracle − bicubic" well below a goal means the goal asks for that.
PSNR in dB over the whole map and over its non-black texels (the chart: what the subject's maps cover).

  /usr/bin/python3 bench/sr_ceiling.py <map.png>... [--factor 4] [--json out.json]
"""
import argparse
import json
import sys

import numpy as np
from PIL import Image

Image.MAX_IMAGE_PIXELS = None


def load(path):
    a = np.asarray(Image.open(path))
    if a.ndim == 2:
        a = a[..., None]
    return a[..., :3].astype(np.float32) / (255 if a.dtype == np.uint8 else 65535)  # 16-bit PNGs open as mode I


def area_down(a, f):
    h, w, c = a.shape
    return a.reshape(h // f, f, w // f, f, c).mean((1, 3))


def bicubic_up(low, f):
    size = (low.shape[1] * f, low.shape[0] * f)
    chans = [np.asarray(Image.fromarray(low[..., c].astype(np.float32), "F").resize(size, Image.BICUBIC))
             for c in range(low.shape[2])]
    return np.stack(chans, -1)


def band_limited(a, f):
    """a with its spectrum cut at the Nyquist frequency of a's f-times downsampled grid."""
    h, w, _ = a.shape
    fy = np.abs(np.fft.fftfreq(h))[:, None]
    fx = np.abs(np.fft.rfftfreq(w))[None, :]
    keep = (fy < 0.5 / f) & (fx < 0.5 / f)
    return np.stack([np.fft.irfft2(np.fft.rfft2(a[..., c]) * keep, s=(h, w)) for c in range(a.shape[2])], -1)


def psnr(a, b, mask=None):
    d = (np.clip(a, 0, 1) - b) ** 2
    d = d[mask] if mask is not None else d
    return float(-10 * np.log10(max(d.mean(), 1e-12)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("maps", nargs="+")
    ap.add_argument("--factor", type=int, default=4)
    ap.add_argument("--json")
    a = ap.parse_args()
    rows = {}
    for path in a.maps:
        try:
            truth = load(path)
        except OSError as e:
            sys.exit(f"sr_ceiling: {path}: cannot read it as an image ({e.strerror or e}); give PNG maps")
        h, w, _ = truth.shape
        if h % a.factor or w % a.factor:
            sys.exit(f"sr_ceiling: {path}: {w}x{h} is not a multiple of {a.factor}; give maps whose side divides")
        chart = truth.max(-1) > 0
        bic = bicubic_up(area_down(truth, a.factor), a.factor)
        band = band_limited(truth, a.factor)
        r = {"bicubic": psnr(bic, truth), "band_oracle": psnr(band, truth),
             "bicubic_chart": psnr(bic, truth, chart), "band_oracle_chart": psnr(band, truth, chart)}
        rows[path] = r
        chart_txt = (f"; in the chart {r['bicubic_chart']:.2f} / {r['band_oracle_chart']:.2f} dB "
                     f"(+{r['band_oracle_chart'] - r['bicubic_chart']:.2f})")
        print(f"{path} ({w}x{h}, x{a.factor}): bicubic {r['bicubic']:.2f} dB, band oracle {r['band_oracle']:.2f} dB "
              f"(+{r['band_oracle'] - r['bicubic']:.2f}){chart_txt}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
