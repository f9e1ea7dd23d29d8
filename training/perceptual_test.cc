// LPIPS on both shipped trunks (zero for identical images, monotone in the noise level, gradients to the input, the
// weights file round trip, missing tensors named) and the identity loss (zero for identical faces, gradients against
// central differences in double, descent lowers it).
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/safetensors.h"
#include "core/test_util.h"
#include "training/identity.h"
#include "training/lpips.h"
#include "training/tensor_io.h"

namespace bareskin::losses {
namespace {

std::string face_api() { return (std::filesystem::path(BARESKIN_ASSETS_DIR) / "face_api").string(); }
bool have_face_api() {
  return std::filesystem::exists(std::filesystem::path(face_api()) / detect::kFaceRecognitionManifest);
}

// A smooth test picture in [0, 1], [B, 3, H, W].
torch::Tensor picture(int64_t b, int64_t h, int64_t w) {
  const torch::Tensor y = torch::linspace(0, 1, h).view({1, 1, h, 1});
  const torch::Tensor x = torch::linspace(0, 1, w).view({1, 1, 1, w});
  const torch::Tensor phase = torch::arange(b * 3, torch::kFloat).view({b, 3, 1, 1});
  return 0.5 + 0.35 * torch::sin(6 * x + 4 * y + phase) * torch::cos(3 * y - 2 * x);
}

class LpipsTrunks : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "facenet") ASSERT_TRUE(have_face_api()) << face_api() << " missing: run 'make deps'";
  }
  Lpips make() const { return Lpips(GetParam(), face_api()); }
};

TEST_P(LpipsTrunks, ZeroForIdenticalImagesAndMonotoneInNoise) {
  Lpips lpips = make();
  EXPECT_EQ(lpips->trunk_name(), GetParam());
  torch::NoGradGuard no_grad;
  torch::manual_seed(4);
  const torch::Tensor clean = picture(2, 48, 40), noise = torch::randn_like(clean);
  EXPECT_LT(lpips->forward(clean, clean).abs().max().item<float>(), 1e-6);
  std::vector<double> values;
  for (const double sigma : {0.01, 0.03, 0.1, 0.3}) {
    const torch::Tensor d = lpips->forward(clean, clean + sigma * noise);
    ASSERT_EQ(d.sizes().vec(), (std::vector<int64_t>{2}));
    values.push_back(d.mean().item<double>());
  }
  std::printf("  %s: LPIPS at noise 0.01, 0.03, 0.1, 0.3: %.5f %.5f %.5f %.5f\n", GetParam().c_str(), values[0],
              values[1], values[2], values[3]);
  for (size_t i = 1; i < values.size(); ++i) EXPECT_GT(values[i], values[i - 1]) << i;
  // Symmetric, and each image of a batch gets its own value.
  const torch::Tensor noisy = clean + 0.1 * noise;
  EXPECT_LT((lpips->forward(clean, noisy) - lpips->forward(noisy, clean)).abs().max().item<float>(), 1e-5);
  EXPECT_NEAR(lpips->forward(clean.slice(0, 1, 2), noisy.slice(0, 1, 2))[0].item<float>(),
              lpips->forward(clean, noisy)[1].item<float>(), 1e-5);
}

TEST_P(LpipsTrunks, GradientsReachTheInputOnly) {
  Lpips lpips = make();
  const torch::Tensor target = picture(1, 32, 32);
  const torch::Tensor x = (target + 0.1 * torch::randn_like(target)).requires_grad_(true);
  const torch::Tensor loss = lpips->forward(x, target).mean();
  loss.backward();
  ASSERT_TRUE(x.grad().defined());
  EXPECT_TRUE(x.grad().isfinite().all().item<bool>());
  EXPECT_GT(x.grad().abs().max().item<float>(), 0);
  for (const auto& p : lpips->parameters()) EXPECT_FALSE(p.grad().defined());
  // A small step against the gradient lowers the distance.
  torch::NoGradGuard no_grad;
  const torch::Tensor step = x - 0.02 * x.grad() / x.grad().abs().max();
  EXPECT_LT(lpips->forward(step, target).mean().item<float>(), loss.item<float>());
}

TEST_P(LpipsTrunks, WeightsFileRoundTripAndMissingTensor) {
  Lpips lpips = make();
  const std::string dir = testing::temp_dir(), path = dir + "/lpips.safetensors";
  // Non-uniform linear weights, so the file must carry them.
  torch::manual_seed(6);
  std::map<std::string, torch::Tensor> tensors;
  lpips->save(path);
  tensors = load_tensors(path);
  for (auto& [name, t] : tensors)
    if (name.rfind("lin", 0) == 0) t = torch::rand_like(t);
  save_tensors(path, tensors, SafeTensors::open(path).metadata());
  Lpips custom(LpipsImpl::load(path));
  EXPECT_EQ(custom->trunk_name(), GetParam());
  const std::string resaved = dir + "/resaved.safetensors";
  custom->save(resaved);
  Lpips reloaded(LpipsImpl::load(resaved));
  torch::NoGradGuard no_grad;
  const torch::Tensor a = picture(2, 32, 32), b = a.flip({3});
  const torch::Tensor value = custom->forward(a, b);
  EXPECT_TRUE(value.equal(reloaded->forward(a, b)));
  EXPECT_GT((value - lpips->forward(a, b)).abs().max().item<float>(), 1e-4);  // the file's weights are used

  // A file without one tensor: InvalidInput naming the file and the tensor. (Files of the VGG trunk are 59 MB: its
  // missing trunk tensor is checked in memory by losses_test's Vgg16 tests, negative weights with facenet only.)
  std::vector<std::string> missing_tensors = {"lin2.model.1.weight"};
  if (GetParam() == "facenet") missing_tensors.push_back(tensors.begin()->first);
  for (const std::string& missing : missing_tensors) {
    auto partial = tensors;
    partial.erase(missing);
    const std::string broken = dir + "/broken.safetensors";
    save_tensors(broken, partial, SafeTensors::open(path).metadata());
    try {
      LpipsImpl::load(broken);
      FAIL() << "no error without " << missing;
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(broken), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
    }
  }
  if (GetParam() == "facenet") {  // negative linear weights are refused
    auto negative = tensors;
    negative["lin0.model.1.weight"] = -negative["lin0.model.1.weight"];
    save_tensors(dir + "/negative.safetensors", negative, SafeTensors::open(path).metadata());
    EXPECT_THROW(LpipsImpl::load(dir + "/negative.safetensors"), InvalidInput);
  }
  std::filesystem::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Trunks, LpipsTrunks, ::testing::Values("vgg16-random", "facenet"),
                         [](const auto& info) { return info.param == "facenet" ? "facenet" : "vgg16_random"; });

TEST(Lpips, DefaultLinearWeightsAndUnknownTrunk) {
  Lpips lpips("vgg16-random");
  ASSERT_EQ(lpips->linear_weights().size(), 5u);
  EXPECT_NEAR(lpips->linear_weights()[4][0].item<float>(), 1.0 / 512, 1e-9);
  EXPECT_EQ(lpips->architecture(), "vgg16");
  EXPECT_THROW(Lpips("alexnet"), InvalidInput);
  const std::string dir = testing::temp_dir();
  save_tensors(dir + "/plain.safetensors", {{"x", torch::zeros({1})}});
  EXPECT_THROW(LpipsImpl::load(dir + "/plain.safetensors"), InvalidInput);  // no trunk metadata
  EXPECT_THROW(LpipsImpl::load(dir + "/absent.safetensors"), IoError);
  std::filesystem::remove_all(dir);
}

TEST(Lpips, CudaMatchesCpu) {
  if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  if (!have_face_api()) GTEST_SKIP() << face_api() << " missing ('make deps')";
  // cuDNN may use TF32 on Ampere and later (10-bit mantissa): compare in full float32 here.
  const bool tf32 = at::globalContext().allowTF32CuDNN();
  at::globalContext().setAllowTF32CuDNN(false);
  torch::NoGradGuard no_grad;
  const torch::Tensor a = picture(2, 64, 64), b = a.flip({3});
  for (const std::string trunk : {"vgg16-random", "facenet"}) {
    Lpips cpu(trunk, face_api()), gpu(trunk, face_api());
    gpu->to(torch::kCUDA);
    const torch::Tensor expected = cpu->forward(a, b);
    const torch::Tensor got = gpu->forward(a.cuda(), b.cuda()).cpu();
    EXPECT_LT((expected - got).abs().max().item<float>(), 1e-4 * expected.abs().max().item<float>()) << trunk;
  }
  detect::FaceRecognitionNet cpu(face_api()), gpu(face_api());
  gpu->to(torch::kCUDA);
  EXPECT_NEAR(identity_loss(cpu, a, b).item<float>(), identity_loss(gpu, a.cuda(), b.cuda()).item<float>(), 1e-4);
  at::globalContext().setAllowTF32CuDNN(tf32);
}

TEST(Identity, ZeroForIdenticalFacesAndGradientsInDouble) {
  ASSERT_TRUE(have_face_api()) << face_api() << " missing: run 'make deps'";
  detect::FaceRecognitionNet net(face_api());
  EXPECT_LT(identity_loss(net, picture(2, 40, 40), picture(2, 40, 40)).item<float>(), 1e-6);
  // Textured inputs in double: on smooth pictures many ReLUs sit near their kink, and central differences are noisy.
  torch::manual_seed(9);
  const torch::Tensor a = torch::rand({2, 3, 12, 10}, torch::kDouble);
  EXPECT_LT(identity_loss(net, a, a).item<double>(), 1e-12);
  const torch::Tensor b = torch::rand({2, 3, 12, 10}, torch::kDouble);
  const torch::Tensor x = a.clone().requires_grad_(true);
  const torch::Tensor loss = identity_loss(net, x, b);
  EXPECT_GT(loss.item<double>(), 1e-4);
  loss.backward();
  const torch::Tensor grad = x.grad();
  ASSERT_TRUE(grad.isfinite().all().item<bool>());
  torch::NoGradGuard no_grad;
  for (int k = 0; k < 3; ++k) {
    const torch::Tensor v = torch::randn_like(a);
    const double h = 1e-7;  // the net is piecewise linear (ReLU, max pool): small steps cross no kink
    const double numeric =
        (identity_loss(net, a + h * v, b).item<double>() - identity_loss(net, a - h * v, b).item<double>()) / (2 * h);
    const double analytic = (grad * v).sum().item<double>();
    // ReLU kinks within ±h of some of the ~10⁶ units leave central differences off by up to ~1e-4 relative; a wrong
    // gradient is off by far more.
    EXPECT_NEAR(analytic, numeric, 1e-3 * std::max(1e-2, std::abs(numeric))) << "direction " << k;
  }
  // Descent along the gradient lowers the loss.
  EXPECT_LT(identity_loss(net, a - 0.01 * grad / grad.abs().max(), b).item<double>(), loss.item<double>());
  const torch::Tensor d = identity_distance(net, a, b);
  EXPECT_EQ(d.sizes().vec(), (std::vector<int64_t>{2}));
  EXPECT_TRUE((d >= 0).all().item<bool>() && (d <= 2).all().item<bool>());
}

}  // namespace
}  // namespace bareskin::losses
