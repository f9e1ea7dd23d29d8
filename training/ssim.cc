#include "training/ssim.h"

#include <torch/torch.h>

#include <cmath>

#include "core/error.h"

namespace bareskin::losses {
namespace F = torch::nn::functional;
namespace {

void check_pair(const torch::Tensor& a, const torch::Tensor& b, const char* what) {
  if (a.dim() != 4 || a.sizes() != b.sizes())
    throw InvalidInput(what, "images of shapes " + c10::str(a.sizes()) + " and " + c10::str(b.sizes()),
                       "pass two [B, C, H, W] batches of the same shape");
}

// Normalised 1-D Gaussian weights exp(−x²/2σ²), x = −r..r.
torch::Tensor gaussian(int window, double sigma, const torch::TensorOptions& options) {
  const torch::Tensor x = torch::arange(window, options) - double(window / 2);
  const torch::Tensor g = torch::exp(-x * x / (2 * sigma * sigma));
  return g / g.sum();
}

}  // namespace

void SsimOptions::check() const {
  if (window < 1 || window % 2 == 0 || !(sigma > 0) || !(data_range > 0) || !(k1 > 0) || !(k2 > 0))
    throw InvalidInput("ssim",
                       "window " + std::to_string(window) + ", sigma " + std::to_string(sigma) + ", data range " +
                           std::to_string(data_range) + ", k1 " + std::to_string(k1) + ", k2 " + std::to_string(k2),
                       "the window must be odd and positive, sigma, data range, k1 and k2 positive");
}

namespace {

void check_window(const torch::Tensor& a, const SsimOptions& options) {
  options.check();
  const int w = options.window;
  if (a.size(2) < w || a.size(3) < w)
    throw InvalidInput("ssim",
                       "images of " + std::to_string(a.size(2)) + "x" + std::to_string(a.size(3)) +
                           " pixels are smaller than the " + std::to_string(w) + "-pixel window",
                       "use larger images or a smaller window");
}

// Each channel of x [B, K, H, W] filtered by the separable Gaussian window over the positions inside the image.
torch::Tensor window_filter(const torch::Tensor& x, const SsimOptions& options) {
  const int w = options.window;
  const int64_t groups = x.size(1);
  const torch::Tensor g = gaussian(w, options.sigma, x.options());
  const torch::Tensor m =
      F::conv2d(x, g.view({1, 1, w, 1}).expand({groups, 1, w, 1}), F::Conv2dFuncOptions().groups(groups));
  return F::conv2d(m, g.view({1, 1, 1, w}).expand({groups, 1, 1, w}), F::Conv2dFuncOptions().groups(groups));
}

// SSIM from the windows' moments [E x, E y, E x², E y², E xy], each [B, C, ...].
torch::Tensor from_moments(const std::vector<torch::Tensor>& parts, const SsimOptions& options) {
  const torch::Tensor &mx = parts[0], &my = parts[1];
  const torch::Tensor vx = parts[2] - mx * mx, vy = parts[3] - my * my, cxy = parts[4] - mx * my;
  const double c1 = std::pow(options.k1 * options.data_range, 2), c2 = std::pow(options.k2 * options.data_range, 2);
  return (2 * mx * my + c1) * (2 * cxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
}

}  // namespace

torch::Tensor ssim_map(const torch::Tensor& a, const torch::Tensor& b, const SsimOptions& options) {
  check_pair(a, b, "ssim");
  check_window(a, options);
  // The five moments filtered at once: a depthwise separable Gaussian over [x, y, x², y², xy].
  return from_moments(window_filter(torch::cat({a, b, a * a, b * b, a * b}, 1), options).split(a.size(1), 1), options);
}

torch::Tensor ssim_map(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& domain,
                       const SsimOptions& options) {
  check_pair(a, b, "ssim");
  check_window(a, options);
  if (domain.dim() != 4 || domain.size(0) != a.size(0) || domain.size(1) != 1 || domain.size(2) != a.size(2) ||
      domain.size(3) != a.size(3))
    throw InvalidInput("ssim", "a domain of shape " + c10::str(domain.sizes()) + " for images of " + c10::str(a.sizes()),
                       "pass the domain as [B, 1, H, W]");
  const torch::Tensor d = domain.to(a.dtype());
  // Σ g·d over each window; where it is 0 the window holds no pixel of the domain, and every moment reads 0.
  const torch::Tensor n = window_filter(d, options).clamp_min(1e-12);
  const torch::Tensor sums = window_filter(d * torch::cat({a, b, a * a, b * b, a * b}, 1), options);
  auto parts = sums.split(a.size(1), 1);
  for (auto& p : parts) p = p / n;
  return from_moments(parts, options);
}

torch::Tensor ssim(const torch::Tensor& a, const torch::Tensor& b, const SsimOptions& options) {
  return ssim_map(a, b, options).mean({1, 2, 3});
}

torch::Tensor psnr(const torch::Tensor& a, const torch::Tensor& b, double data_range) {
  check_pair(a, b, "psnr");
  const torch::Tensor mse = (a - b).pow(2).mean({1, 2, 3});
  return 10 * torch::log10(data_range * data_range / mse);
}

torch::Tensor psnr(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask, double data_range) {
  check_pair(a, b, "psnr");
  const torch::Tensor m = mask.expand_as(a);
  const torch::Tensor mse = ((a - b).pow(2) * m).sum({1, 2, 3}) / m.sum({1, 2, 3}).clamp_min(1);
  return 10 * torch::log10(data_range * data_range / mse);
}

}  // namespace bareskin::losses
