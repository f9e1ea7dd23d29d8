// Pixel, GAN and structural losses against their formulas written out element by element, SSIM/PSNR against
// scikit-image, and the seeded VGG16 trunk + LPIPS formula against torchvision (tests/python/losses_oracle.py).
#include "training/losses.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "core/test_util.h"
#include "training/ssim.h"
#include "training/vgg16.h"

namespace bareskin::losses {
namespace {

TEST(Losses, L1AndMaskedL1) {
  const torch::Tensor a = torch::tensor({1.0, 2.0, 3.0, 4.0}).view({1, 1, 2, 2});
  const torch::Tensor b = torch::tensor({0.0, 4.0, 3.0, 0.0}).view({1, 1, 2, 2});
  EXPECT_DOUBLE_EQ(l1(a, b).item<double>(), (1 + 2 + 0 + 4) / 4.0);
  const torch::Tensor mask = torch::tensor({1.0, 1.0, 0.0, 0.0}).view({1, 1, 2, 2});
  EXPECT_DOUBLE_EQ(masked_l1(a, b, mask).item<double>(), (1 + 2) / 2.0);
  // A [B, 1, H, W] mask over 3 channels counts each pixel once per channel; soft weights weight.
  const torch::Tensor a3 = a.expand({1, 3, 2, 2}) * torch::tensor({1.0, 2.0, 3.0}).view({1, 3, 1, 1});
  const torch::Tensor b3 = torch::zeros_like(a3);
  const torch::Tensor soft = torch::tensor({0.5, 0.0, 0.0, 1.0}).view({1, 1, 2, 2});
  EXPECT_NEAR(masked_l1(a3, b3, soft).item<double>(), (0.5 * 1 + 1 * 4) * (1 + 2 + 3) / (1.5 * 3), 1e-12);
  const torch::Tensor empty = torch::zeros_like(mask);
  EXPECT_EQ(masked_l1(a, b, empty).item<double>(), 0);
  // The gradient reaches only the masked pixels.
  const torch::Tensor x = a.clone().requires_grad_(true);
  masked_l1(x, b, mask).backward();
  EXPECT_TRUE(x.grad().equal(torch::tensor({0.5, -0.5, 0.0, 0.0}).view({1, 1, 2, 2})));
}

TEST(Losses, GanLossesFollowTheirFormulas) {
  const std::vector<double> logits = {-2.0, -0.3, 0.0, 0.7, 3.0};
  const torch::Tensor p = torch::tensor(logits, torch::kDouble).view({1, 1, 1, 5});
  auto mean = [&](auto f) {
    double s = 0;
    for (double x : logits) s += f(x);
    return s / double(logits.size());
  };
  auto softplus = [](double x) { return std::log1p(std::exp(x)); };  // −log σ(−x)
  const double tol = 1e-12;
  EXPECT_NEAR(gan_loss(p, true, GanKind::Vanilla, true).item<double>(), mean([&](double x) { return softplus(-x); }),
              tol);
  EXPECT_NEAR(gan_loss(p, false, GanKind::Vanilla, true).item<double>(), mean([&](double x) { return softplus(x); }),
              tol);
  EXPECT_NEAR(gan_loss(p, true, GanKind::Lsgan, true).item<double>(), mean([](double x) { return (x - 1) * (x - 1); }),
              tol);
  EXPECT_NEAR(gan_loss(p, false, GanKind::Lsgan, false).item<double>(), mean([](double x) { return x * x; }), tol);
  EXPECT_NEAR(gan_loss(p, true, GanKind::Hinge, true).item<double>(),
              mean([](double x) { return std::max(0.0, 1 - x); }), tol);
  EXPECT_NEAR(gan_loss(p, false, GanKind::Hinge, true).item<double>(),
              mean([](double x) { return std::max(0.0, 1 + x); }), tol);
  EXPECT_NEAR(gan_loss(p, true, GanKind::Hinge, false).item<double>(), -mean([](double x) { return x; }), tol);
  // The vanilla and LSGAN losses do not depend on who asks.
  EXPECT_EQ(gan_loss(p, true, GanKind::Lsgan, false).item<double>(),
            gan_loss(p, true, GanKind::Lsgan, true).item<double>());
  EXPECT_THROW(gan_loss(p, false, GanKind::Hinge, false), InternalError);

  // Multiscale: the sum over scales of each scale's last output; features are ignored.
  const MultiscaleOutputs outputs = {{torch::ones({1, 4, 8, 8}) * 7, p}, {p * 2}};
  EXPECT_NEAR(gan_loss(outputs, true, GanKind::Lsgan, true).item<double>(),
              gan_loss(p, true, GanKind::Lsgan, true).item<double>() +
                  gan_loss(p * 2, true, GanKind::Lsgan, true).item<double>(),
              tol);

  EXPECT_EQ(parse_gan_kind("lsgan"), GanKind::Lsgan);
  EXPECT_EQ(gan_kind_name(parse_gan_kind("hinge")), "hinge");
  try {
    parse_gan_kind("wgan", "config.json: gan_loss");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("config.json: gan_loss"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("wgan"), std::string::npos) << e.what();
  }
}

TEST(Losses, FeatureMatchingAsPix2PixHD) {
  torch::manual_seed(3);
  // Two scales of a discriminator with n_layers_D = 3: four feature maps and a prediction each.
  MultiscaleOutputs fake(2), real(2);
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < 5; ++j) {
      fake[s].push_back(torch::randn({2, 3, 6 - j, 6 - j}, torch::kDouble).requires_grad_(true));
      real[s].push_back(torch::randn({2, 3, 6 - j, 6 - j}, torch::kDouble).requires_grad_(true));
    }
  double expected = 0;
  for (int s = 0; s < 2; ++s)
    for (int j = 0; j < 4; ++j) {
      const auto f = fake[s][j].accessor<double, 4>(), r = real[s][j].accessor<double, 4>();
      double sum = 0;
      int64_t n = 0;
      for (int64_t a = 0; a < f.size(0); ++a)
        for (int64_t b = 0; b < f.size(1); ++b)
          for (int64_t c = 0; c < f.size(2); ++c)
            for (int64_t d = 0; d < f.size(3); ++d, ++n) sum += std::abs(f[a][b][c][d] - r[a][b][c][d]);
      expected += (1.0 / 2) * (4.0 / (3 + 1)) * (sum / double(n)) * 10;
    }
  const torch::Tensor loss = feature_matching(fake, real);
  EXPECT_NEAR(loss.item<double>(), expected, 1e-10);
  loss.backward();
  EXPECT_TRUE(fake[0][0].grad().defined());
  EXPECT_FALSE(real[0][0].grad().defined());  // real features are detached
  EXPECT_FALSE(fake[0][4].grad().defined());  // predictions are not matched
  MultiscaleOutputs short_real = real;
  short_real.pop_back();
  EXPECT_THROW(feature_matching(fake, short_real), InvalidInput);
}

// Raw float64 [N, C, H, W] for the Python oracle.
void write_raw(const std::string& path, const torch::Tensor& t) {
  const torch::Tensor c = t.to(torch::kDouble).contiguous();
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(c.data_ptr<double>()), std::streamsize(c.numel() * sizeof(double)));
}

// Runs the oracle on two batches; skips the test when /usr/bin/python3 lacks the module it needs.
nlohmann::json oracle(const std::string& command, const torch::Tensor& a, const torch::Tensor& b,
                      const std::string& extra) {
  const std::string dir = testing::temp_dir();
  write_raw(dir + "/a.bin", a);
  write_raw(dir + "/b.bin", b);
  std::ostringstream cmd;
  cmd << "/usr/bin/python3 '" BARESKIN_LOSSES_ORACLE "' " << command << " '" << dir << "/a.bin' '" << dir << "/b.bin' "
      << a.size(0) << " " << a.size(1) << " " << a.size(2) << " " << a.size(3) << " " << extra << " > '" << dir
      << "/out.json' 2> '" << dir << "/err.txt'";
  const int rc = std::system(cmd.str().c_str());
  std::ostringstream err;
  err << std::ifstream(dir + "/err.txt").rdbuf();
  nlohmann::json result;
  if (rc == 0) result = nlohmann::json::parse(std::ifstream(dir + "/out.json"));
  std::filesystem::remove_all(dir);
  if (rc != 0) result["error"] = err.str();
  return result;
}

// Two fixed related images: a smooth pattern and a blurred, noisier, brighter copy.
std::pair<torch::Tensor, torch::Tensor> image_pair(int64_t n, int64_t c, int64_t h, int64_t w, double scale) {
  torch::manual_seed(11);
  const torch::Tensor y = torch::linspace(0, 1, h, torch::kDouble).view({1, 1, h, 1});
  const torch::Tensor x = torch::linspace(0, 1, w, torch::kDouble).view({1, 1, 1, w});
  const torch::Tensor phase = torch::arange(n * c, torch::kDouble).view({n, c, 1, 1});
  const torch::Tensor a =
      0.5 + 0.3 * torch::sin(7 * x + 5 * y * y + phase) + 0.1 * torch::rand({n, c, h, w}, torch::kDouble);
  const torch::Tensor b = 0.9 * a + 0.08 + 0.05 * torch::randn({n, c, h, w}, torch::kDouble);
  return {a * scale, b * scale};
}

TEST(Ssim, MatchesScikitImage) {
  for (const double range : {1.0, 255.0}) {
    const auto [a, b] = image_pair(2, 3, 37, 29, range);
    const nlohmann::json ref = oracle("ssim", a, b, std::to_string(range));
    if (ref.contains("error")) FAIL() << "scikit-image oracle failed (make deps installs python3-skimage): " << ref["error"];
    SsimOptions options;
    options.data_range = range;
    const torch::Tensor s = ssim(a, b, options), p = psnr(a, b, range);
    for (int i = 0; i < 2; ++i) {
      const double ref_ssim = ref["ssim"][i], ref_psnr = ref["psnr"][i];
      std::printf("  range %g image %d: SSIM %.6f (skimage %.6f), PSNR %.4f dB (skimage %.4f)\n", range, i,
                  s[i].item<double>(), ref_ssim, p[i].item<double>(), ref_psnr);
      EXPECT_NEAR(s[i].item<double>(), ref_ssim, 1e-4);
      EXPECT_NEAR(p[i].item<double>(), ref_psnr, 1e-6);
    }
    // float32 agrees too.
    EXPECT_NEAR(ssim(a.to(torch::kFloat), b.to(torch::kFloat), options)[0].item<double>(), double(ref["ssim"][0]),
                1e-4);
  }
}

TEST(Ssim, IdentityGradientsAndBadInput) {
  const auto [a, b] = image_pair(1, 3, 16, 16, 1);
  EXPECT_NEAR(ssim(a, a)[0].item<double>(), 1, 1e-12);
  EXPECT_TRUE(std::isinf(psnr(a, a)[0].item<double>()));
  const torch::Tensor x = b.clone().requires_grad_(true);
  (1 - ssim(x, a).mean()).backward();
  EXPECT_TRUE(x.grad().isfinite().all().item<bool>());
  // A small step against the gradient raises SSIM.
  const double before = ssim(b, a)[0].item<double>();
  EXPECT_GT(ssim(b - 1e-3 * x.grad() / x.grad().abs().max(), a)[0].item<double>(), before);
  EXPECT_THROW(ssim(a.slice(2, 0, 10), b.slice(2, 0, 10)), InvalidInput);  // smaller than the window
  EXPECT_THROW(ssim(a, b.slice(3, 0, 12)), InvalidInput);                  // shapes differ
  SsimOptions even;
  even.window = 10;
  EXPECT_THROW(ssim(a, b, even), InvalidInput);
}

TEST(Ssim, DomainWindowsCompareTheDomainAlone) {
  const auto [a, b] = image_pair(2, 3, 24, 20, 1);
  const SsimOptions o;
  // A domain of ones is the plain map.
  EXPECT_TRUE(torch::allclose(ssim_map(a, b, torch::ones({2, 1, 24, 20}, torch::kDouble), o), ssim_map(a, b, o),
                              1e-12, 1e-12));
  // A domain: the left 12 columns and a hole; one window position checked against its weighted moments, summed here.
  auto d = torch::zeros({2, 1, 24, 20}, torch::kDouble);
  d.narrow(3, 0, 12).fill_(1);
  d.narrow(2, 8, 3).narrow(3, 2, 3).zero_();
  const torch::Tensor map = ssim_map(a, b, d, o);
  const int64_t i0 = 3, j0 = 4, r = o.window / 2;  // the window centred on (i0 + r, j0 + r): straddles the edge
  std::vector<double> g(size_t(o.window));
  double gs = 0;
  for (int u = 0; u < o.window; ++u) gs += g[size_t(u)] = std::exp(-double((u - r) * (u - r)) / (2 * o.sigma * o.sigma));
  for (int64_t c = 0; c < 3; ++c) {
    double n = 0, sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
    for (int u = 0; u < o.window; ++u)
      for (int v = 0; v < o.window; ++v) {
        const double w = g[size_t(u)] * g[size_t(v)] / (gs * gs) * d[1][0][i0 + u][j0 + v].item<double>();
        const double x = a[1][c][i0 + u][j0 + v].item<double>(), y = b[1][c][i0 + u][j0 + v].item<double>();
        n += w, sx += w * x, sy += w * y, sxx += w * x * x, syy += w * y * y, sxy += w * x * y;
      }
    const double mx = sx / n, my = sy / n, vx = sxx / n - mx * mx, vy = syy / n - my * my, cxy = sxy / n - mx * my;
    const double c1 = 1e-4, c2 = 9e-4;
    const double expect = (2 * mx * my + c1) * (2 * cxy + c2) / ((mx * mx + my * my + c1) * (vx + vy + c2));
    EXPECT_NEAR(map[1][c][i0][j0].item<double>(), expect, 1e-12);
  }
  // What lies off the domain does not count; a pair equal on it scores 1 at every position.
  const torch::Tensor b_off = b + (1 - d) * torch::rand_like(b);
  EXPECT_TRUE(torch::allclose(ssim_map(a, b_off, d, o), map, 1e-12, 1e-12));
  EXPECT_LT(ssim_map(a, b_off, o).mean().item<double>(), ssim_map(a, b, o).mean().item<double>());
  EXPECT_NEAR(ssim_map(a, a + (1 - d) * 0.3, d, o).min().item<double>(), 1.0, 1e-12);
  EXPECT_THROW(ssim_map(a, b, d.narrow(3, 0, 19), o), InvalidInput);
}

TEST(Vgg16, SeededTrunkAndLpipsFormulaMatchTorchvision) {
  const auto [a, b] = image_pair(2, 3, 32, 40, 1);
  const nlohmann::json ref = oracle("lpips-vgg16-random", a, b, std::to_string(Vgg16FeaturesImpl::kRandomSeed));
  if (ref.contains("error")) FAIL() << "torchvision oracle failed (make deps installs python3-torchvision): " << ref["error"];
  Vgg16Features vgg;
  EXPECT_NEAR(vgg->weights().at("features.0.weight").sum().item<double>(), double(ref["conv1_1_weight_sum"]), 1e-4);
  // LPIPS with lin weights 1/C, written out here from the trunk's features.
  torch::NoGradGuard no_grad;
  const auto fa = vgg->forward(a.to(torch::kFloat)), fb = vgg->forward(b.to(torch::kFloat));
  ASSERT_EQ(fa.size(), 5u);
  const std::vector<std::vector<int64_t>> shapes = {
      {2, 64, 32, 40}, {2, 128, 16, 20}, {2, 256, 8, 10}, {2, 512, 4, 5}, {2, 512, 2, 2}};
  torch::Tensor total = torch::zeros({2}, torch::kDouble);
  for (size_t l = 0; l < fa.size(); ++l) {
    EXPECT_EQ(fa[l].sizes().vec(), shapes[l]);
    const torch::Tensor x = fa[l].to(torch::kDouble), y = fb[l].to(torch::kDouble);
    const torch::Tensor nx = x / torch::sqrt(x.pow(2).sum(1, true) + 1e-10);
    const torch::Tensor ny = y / torch::sqrt(y.pow(2).sum(1, true) + 1e-10);
    total += (nx - ny).pow(2).mean(1).mean({1, 2});
  }
  for (int i = 0; i < 2; ++i) {
    const double expected = ref["lpips"][i];
    std::printf("  image %d: LPIPS(vgg16-random) %.6f, torchvision %.6f\n", i, total[i].item<double>(), expected);
    EXPECT_NEAR(total[i].item<double>(), expected, 1e-5 * expected);
  }
}

TEST(Vgg16, WeightsRoundTripAndMissingTensor) {
  Vgg16Features vgg, other;
  other->random_init(7);
  EXPECT_FALSE(other->weights().at("features.28.weight").equal(vgg->weights().at("features.28.weight")));
  other->load_weights(vgg->weights(), "copy");
  for (const auto& [name, w] : vgg->weights()) EXPECT_TRUE(w.equal(other->weights().at(name))) << name;
  auto weights = vgg->weights();
  EXPECT_EQ(weights.size(), 26u);
  weights.erase("features.17.bias");
  try {
    other->load_weights(weights, "trunk.safetensors");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("trunk.safetensors"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("features.17.bias"), std::string::npos) << e.what();
  }
  for (const auto& p : vgg->parameters()) EXPECT_FALSE(p.requires_grad());
}

}  // namespace
}  // namespace bareskin::losses
