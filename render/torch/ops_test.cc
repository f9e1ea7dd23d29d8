// The Torch ops against the kernel and against finite differences: interpolate equals the kernel's interpolation;
// its gradients in double match central differences (the covered pixels held fixed); texture equals core's bilinear
// lookup; bad shapes and NaN are refused.
#include <gtest/gtest.h>

#include <random>

#include "core/image.h"
#include "render/rasterize.h"
#include "render/sh.h"
#include "core/error.h"
#include "render/torch/ops.h"

namespace bareskin {
namespace {

using namespace render_torch;

// Triangles in pixel space with depths, random but facing any way; V = 3 * count.
torch::Tensor soup(int count, int size, torch::Dtype dtype, uint64_t seed) {
  torch::manual_seed(seed);
  torch::Tensor centre = torch::rand({count, 1, 2}, torch::kDouble) * (size - 8) + 4;
  torch::Tensor xy = centre + (torch::rand({count, 3, 2}, torch::kDouble) - 0.5) * size * 0.6;
  torch::Tensor w = torch::rand({count, 3, 1}, torch::kDouble) * 2 + 1;
  return torch::cat({xy, w}, 2).reshape({1, 3 * count, 3}).to(dtype);
}

torch::Tensor soup_triangles(int count) { return torch::arange(3 * count, torch::kLong).reshape({count, 3}); }

TEST(RenderTorch, InterpolateEqualsTheKernel) {
  const int size = 64, count = 40;
  const torch::Tensor pos = torch::cat({soup(count, size, torch::kFloat, 1), soup(count, size, torch::kFloat, 2)}, 0);
  const torch::Tensor tri = soup_triangles(count);
  const torch::Tensor attr = torch::rand({2, 3 * count, 4});
  const Raster r = rasterize(pos, tri, size, size);
  const torch::Tensor out = interpolate(attr, pos, tri, r);
  ASSERT_EQ(out.sizes(), torch::IntArrayRef({2, size, size, 4}));
  const torch::Tensor t32 = tri.to(torch::kInt).contiguous();
  for (int b = 0; b < 2; ++b) {
    const torch::Tensor pb = pos[b].contiguous(), ab = attr[b].contiguous();
    RasterInput in;
    in.xyw = pb.data_ptr<float>();
    in.triangles = t32.data_ptr<int32_t>();
    in.vertex_count = 3 * count;
    in.triangle_count = count;
    in.width = in.height = size;
    const RasterOutput k = bareskin::rasterize(in);
    const std::vector<float> ref = bareskin::interpolate(k, t32.data_ptr<int32_t>(), ab.data_ptr<float>(), 4);
    const torch::Tensor ref_t = torch::from_blob(const_cast<float*>(ref.data()), {size, size, 4});
    EXPECT_LT((out[b] - ref_t).abs().max().item<float>(), 1e-4) << "batch " << b;
    EXPECT_GT((r.triangle[b] >= 0).sum().item<int64_t>(), size * size / 4);
  }
}

TEST(RenderTorch, GradientsMatchFiniteDifferences) {
  const int size = 24, count = 4, C = 2;
  torch::Tensor pos = soup(count, size, torch::kDouble, 5).requires_grad_(true);
  torch::Tensor attr = torch::rand({1, 3 * count, C}, torch::kDouble).requires_grad_(true);
  const torch::Tensor tri = soup_triangles(count);
  const torch::Tensor weights = torch::rand({1, size, size, C}, torch::kDouble);
  const Raster r = rasterize(pos, tri, size, size);  // held fixed
  const auto loss = [&](const torch::Tensor& p, const torch::Tensor& a) { return (interpolate(a, p, tri, r) * weights).sum(); };
  const torch::Tensor L = loss(pos, attr);
  const auto grads = torch::autograd::grad({L}, {pos, attr});
  const double eps = 1e-6;
  double worst = 0, scale = 0;
  for (int which = 0; which < 2; ++which) {
    const torch::Tensor base = (which == 0 ? pos : attr).detach();
    const torch::Tensor g = grads[size_t(which)].reshape({-1});
    for (int64_t i = 0; i < base.numel(); ++i) {
      torch::Tensor plus = base.clone(), minus = base.clone();
      plus.view({-1})[i] += eps;
      minus.view({-1})[i] -= eps;
      const double fp = (which == 0 ? loss(plus, attr.detach()) : loss(pos.detach(), plus)).item<double>();
      const double fm = (which == 0 ? loss(minus, attr.detach()) : loss(pos.detach(), minus)).item<double>();
      const double numeric = (fp - fm) / (2 * eps);
      worst = std::max(worst, std::abs(numeric - g[i].item<double>()));
      scale = std::max(scale, std::abs(numeric));
    }
  }
  EXPECT_GT(scale, 1e-3) << "the loss must depend on the inputs";
  EXPECT_LT(worst, 1e-6 * std::max(1.0, scale)) << "max |autograd - central difference|";
}

TEST(RenderTorch, TextureEqualsBilinear) {
  torch::manual_seed(3);
  const torch::Tensor tex = torch::rand({1, 3, 8, 10});
  const torch::Tensor uv = torch::rand({1, 5, 7, 2}) * 1.2 - 0.1;  // some outside [0, 1]: border
  const torch::Tensor out = texture(tex, uv);
  Image img(10, 8, 3);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 10; ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = tex[0][c][y][x].item<float>();
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 7; ++j) {
      const Eigen::Vector3f ref = sample_bilinear(img, {uv[0][i][j][0].item<float>(), uv[0][i][j][1].item<float>()});
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(out[0][i][j][c].item<float>(), ref[c], 1e-5);
    }
}

TEST(RenderTorch, ShShadeEqualsCoreIrradiance) {
  torch::manual_seed(4);
  const torch::Tensor normal = torch::randn({2, 3, 5, 3}, torch::kDouble) * 2;  // not unit: the op normalises
  const torch::Tensor albedo = torch::rand({2, 3, 5, 3}, torch::kDouble);
  const torch::Tensor gamma = torch::randn({2, 27}, torch::kDouble) * 0.3;
  const torch::Tensor out = sh_shade(albedo, normal, gamma);
  for (int b = 0; b < 2; ++b)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 5; ++j) {
        const torch::Tensor n = normal[b][i][j];
        const Eigen::Vector3d nv = Eigen::Vector3d(n[0].item<double>(), n[1].item<double>(), n[2].item<double>()).normalized();
        const torch::Tensor g = gamma[b].contiguous();
        const Eigen::Vector3d e = sh_irradiance(nv, g.data_ptr<double>());
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(out[b][i][j][c].item<double>(), albedo[b][i][j][c].item<double>() * e[c], 1e-12);
      }
  EXPECT_THROW(sh_shade(albedo, normal, gamma.narrow(1, 0, 9)), InvalidInput);
}

// The CUDA rasterizer against the CPU one, and the differentiable render (interpolate + SH shading + loss) forward and
// backward on both devices. Runs where the build has the CUDA rasterizer and a GPU is present; skips cleanly elsewhere.
TEST(RenderTorch, CudaMatchesCpu) {
  if (!cuda_rasterizer_built()) GTEST_SKIP() << "built without the CUDA rasterizer";
  if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  const int size = 96, count = 3000;
  const torch::Tensor pos = torch::cat({soup(count, size, torch::kFloat, 7), soup(count, size, torch::kFloat, 8)}, 0);
  // Ties: the first 100 triangles again under higher ids.
  const torch::Tensor tri = torch::cat({soup_triangles(count), soup_triangles(100)}, 0);
  const torch::Device gpu(torch::kCUDA);
  for (bool cull : {false, true}) {
    const Raster c = rasterize(pos, tri, size, size, cull), g = rasterize(pos.to(gpu), tri.to(gpu), size, size, cull);
    EXPECT_TRUE(torch::equal(c.triangle, g.triangle.cpu())) << "cull " << cull;
    EXPECT_TRUE(torch::equal(c.bary, g.bary.cpu())) << "cull " << cull;
  }
  torch::manual_seed(9);
  const torch::Tensor attr = torch::rand({2, 3 * count, 3}), normal = torch::randn({2, 3 * count, 3}), gamma = torch::randn({2, 27}) * 0.3;
  const torch::Tensor target = torch::rand({2, size, size, 3});
  std::vector<torch::Tensor> results;
  for (const torch::Device device : {torch::Device(torch::kCPU), gpu}) {
    const torch::Tensor p = pos.to(device).requires_grad_(true), a = attr.to(device).requires_grad_(true);
    const torch::Tensor n = normal.to(device), t = tri.to(device);
    const Raster r = rasterize(p, t, size, size);
    const torch::Tensor image = sh_shade(interpolate(a, p, t, r), interpolate(n, p, t, r), gamma.to(device));
    const torch::Tensor loss = (image - target.to(device)).pow(2).mean();
    loss.backward();
    results.insert(results.end(), {image.cpu(), p.grad().cpu(), a.grad().cpu()});
  }
  for (int k = 0; k < 3; ++k) {
    const double scale = results[size_t(k)].abs().max().item<double>();
    EXPECT_LT((results[size_t(k)] - results[size_t(k) + 3]).abs().max().item<double>(), 1e-4 * std::max(1.0, scale))
        << (k == 0 ? "image" : k == 1 ? "d loss / d pos" : "d loss / d attr");
  }
}

// CUDA tensors are not read back per call: a triangle with an index out of range or a NaN corner is dropped on the
// device (the image equals the one without it); the debug switch checks them on the host and throws instead.
TEST(RenderTorch, CudaBadValuesDroppedOnDeviceOrCheckedUnderTheSwitch) {
  if (!cuda_rasterizer_built()) GTEST_SKIP() << "built without the CUDA rasterizer";
  if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  const torch::Device gpu(torch::kCUDA);
  const torch::Tensor pos = soup(3, 32, torch::kFloat, 1).to(gpu);
  const torch::Tensor good = soup_triangles(2).to(gpu);  // the first two triangles
  torch::Tensor bad = soup_triangles(3).to(gpu).clone();
  bad[2][1] = 1000;  // the third triangle: an index out of range
  ASSERT_FALSE(device_checks());
  const Raster kept = rasterize(pos, good, 32, 32), dropped = rasterize(pos, bad, 32, 32);
  EXPECT_TRUE(torch::equal(kept.triangle.cpu(), dropped.triangle.cpu()));
  set_device_checks(true);
  EXPECT_THROW(rasterize(pos, bad, 32, 32), InvalidInput);
  torch::Tensor nan_pos = pos.clone();
  nan_pos[0][0][0] = NAN;
  EXPECT_THROW(rasterize(nan_pos, good, 32, 32), InvalidInput);
  set_device_checks(false);
}

TEST(RenderTorch, RefusesBadInput) {
  const torch::Tensor tri = soup_triangles(2);
  torch::Tensor pos = soup(2, 16, torch::kFloat, 1);
  EXPECT_THROW(rasterize(pos.reshape({6, 3}), tri, 16, 16), InvalidInput);
  pos[0][1][0] = NAN;
  EXPECT_THROW(rasterize(pos, tri, 16, 16), InvalidInput);
  EXPECT_THROW(rasterize(soup(2, 16, torch::kFloat, 1), tri + 10, 16, 16), InvalidInput);
}

}  // namespace
}  // namespace bareskin
