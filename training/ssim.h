// Structural similarity (Wang et al., "Image quality assessment: from error visibility to structural similarity",
// IEEE TIP 2004) with its Gaussian window, and PSNR. Differentiable; images [B, C, H, W] of any float dtype.
#pragma once
#include <torch/types.h>

namespace bareskin::losses {

struct SsimOptions {
  int window = 11;     // Gaussian window side (odd); 11 = 2·round(3.5σ) + 1 for σ = 1.5
  double sigma = 1.5;  // Gaussian standard deviation, pixels
  double k1 = 0.01, k2 = 0.03;
  double data_range = 1.0;  // L: max − min of the pixel scale (1 for [0, 1], 2 for [−1, 1], 255 for 8-bit)
  void check() const;       // InvalidInput for an even window or a non-positive constant
};

// The SSIM map over the window positions that lie inside the image: [B, C, H − window + 1, W − window + 1], with
// μ, σ², σxy the Gaussian-weighted means, (population) variances and covariance, C1 = (k1·L)², C2 = (k2·L)²:
//   SSIM = (2μxμy + C1)(2σxy + C2) / ((μx² + μy² + C1)(σx² + σy² + C2)).
// InvalidInput when the images differ in shape or are smaller than the window.
torch::Tensor ssim_map(const torch::Tensor& a, const torch::Tensor& b, const SsimOptions& options = {});

// The same with each window's moments taken over the pixels of `domain` ([B, 1, H, W], weights in [0, 1]) alone:
// μx = Σ g·d·x / Σ g·d and likewise for σ², σxy (g the window's Gaussian, d the domain). For a pair whose truth
// exists on part of the image only (a face's bare albedo, black off the face), a window on that part's edge compares
// the two images where the truth is, and what lies off it does not count. A domain of ones gives the map above; a
// window with no pixel of the domain reads 1.
torch::Tensor ssim_map(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& domain,
                       const SsimOptions& options = {});

// Mean SSIM per image, [B]: the map's mean over channels and positions. Equals scikit-image's
// structural_similarity(gaussian_weights=True, sigma=1.5, use_sample_covariance=False, data_range=L, channel_axis).
// A loss is 1 − ssim(a, b).mean().
torch::Tensor ssim(const torch::Tensor& a, const torch::Tensor& b, const SsimOptions& options = {});

// Peak signal-to-noise ratio per image, [B], in dB: 10·log10(L² / mean((a − b)²)) (inf for identical images).
torch::Tensor psnr(const torch::Tensor& a, const torch::Tensor& b, double data_range = 1.0);
// The same over the texels where `mask` ([B, 1, H, W], 0 or 1) is 1: the mean squared error over those texels and all
// channels.
torch::Tensor psnr(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask, double data_range = 1.0);

}  // namespace bareskin::losses
