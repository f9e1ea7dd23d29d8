// face-api's face recognition net: descriptors against face-api's own JavaScript (node, tfjs CPU backend) on a
// 150² image and on a non-square one (centred padding + legacy resize), feature-map shapes, gradients to the input
// (directional derivatives in double against central differences), weights round trip, and missing tensors.
#include "detect/face_recognition.h"

#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "core/test_util.h"

namespace bareskin::detect {
namespace {

std::string folder() { return (std::filesystem::path(BARESKIN_ASSETS_DIR) / "face_api").string(); }

bool have_weights() { return std::filesystem::exists(std::filesystem::path(folder()) / kFaceRecognitionManifest); }

// A fixed 8-bit test picture: smooth colour waves plus pseudo-random noise from a 32-bit LCG.
std::vector<uint8_t> picture(int height, int width) {
  std::vector<uint8_t> pixels(size_t(height) * width * 3);
  uint32_t state = 12345;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) {
        state = state * 1664525u + 1013904223u;
        const double noise = double(state >> 24) / 255.0 * 40 - 20;
        const double v = 128 + 60 * std::sin(0.07 * x + c) + 40 * std::cos(0.05 * (c + 1) * y) + noise;
        pixels[(size_t(y) * width + x) * 3 + c] = uint8_t(std::clamp(v, 0.0, 255.0));
      }
  return pixels;
}

void write_ppm(const std::string& path, const std::vector<uint8_t>& pixels, int height, int width) {
  std::ofstream out(path, std::ios::binary);
  out << "P6\n" << width << " " << height << "\n255\n";
  out.write(reinterpret_cast<const char*>(pixels.data()), std::streamsize(pixels.size()));
}

torch::Tensor to_input(const std::vector<uint8_t>& pixels, int height, int width) {  // [1, 3, H, W] in [0, 1]
  return torch::tensor(std::vector<float>(pixels.begin(), pixels.end()))
             .view({height, width, 3})
             .permute({2, 0, 1})
             .unsqueeze(0)
             .contiguous() /
         255;
}

TEST(FaceRecognition, MatchesFaceApiJavaScript) {
  if (!have_weights()) GTEST_SKIP() << folder() << " has no face recognition model ('make deps')";
  if (std::system("command -v node > /dev/null 2>&1") != 0) GTEST_SKIP() << "node not installed";
  const std::string dir = testing::temp_dir();
  const std::vector<std::pair<int, int>> sizes = {{150, 150}, {96, 131}};  // 131 − 96 = 35: odd padding split
  std::string command = "node '" BARESKIN_TEST_NODE_DIR "/face_recognition_reference.mjs' '" + folder() + "'";
  std::vector<torch::Tensor> inputs;
  for (size_t i = 0; i < sizes.size(); ++i) {
    const auto [h, w] = sizes[i];
    const auto pixels = picture(h, w);
    const std::string ppm = dir + "/image" + std::to_string(i) + ".ppm";
    write_ppm(ppm, pixels, h, w);
    inputs.push_back(to_input(pixels, h, w));
    command += " '" + ppm + "'";
  }
  const std::string json_path = dir + "/reference.json";
  ASSERT_EQ(std::system((command + " > '" + json_path + "' 2> '" + dir + "/node.err'").c_str()), 0)
      << "node failed: " << std::ifstream(dir + "/node.err").rdbuf();
  const auto reference = nlohmann::json::parse(std::ifstream(json_path));
  ASSERT_EQ(reference.at("descriptors").size(), sizes.size());

  FaceRecognitionNet net(folder());
  torch::NoGradGuard no_grad;
  for (size_t i = 0; i < sizes.size(); ++i) {
    const auto expected = reference["descriptors"][i].get<std::vector<float>>();
    ASSERT_EQ(expected.size(), 128u);
    const torch::Tensor ours = net->forward(inputs[i])[0];
    const float diff = (ours - torch::tensor(expected)).abs().max().item<float>();
    std::printf("  %dx%d: max |ours - face-api| = %.2e (descriptor norm %.3f)\n", sizes[i].first, sizes[i].second, diff,
                ours.norm().item<float>());
    EXPECT_LT(diff, 1e-4) << sizes[i].first << "x" << sizes[i].second;
  }
  std::filesystem::remove_all(dir);
}

TEST(FaceRecognition, FeatureMapsAndBatches) {
  if (!have_weights()) GTEST_SKIP() << folder() << " missing ('make deps')";
  FaceRecognitionNet net(folder());
  torch::NoGradGuard no_grad;
  torch::manual_seed(1);
  const torch::Tensor images = torch::rand({2, 3, 64, 80});
  const auto out = net->forward_features(images);
  ASSERT_EQ(out.features.size(), size_t(FaceRecognitionNetImpl::kFeatureLevels));
  const std::vector<std::vector<int64_t>> shapes = {
      {2, 32, 72, 72}, {2, 32, 35, 35}, {2, 64, 17, 17}, {2, 128, 8, 8}, {2, 256, 4, 4}};
  for (size_t i = 0; i < shapes.size(); ++i) {
    EXPECT_EQ(out.features[i].sizes().vec(), shapes[i]) << i;
    EXPECT_EQ(out.features[i].size(1), FaceRecognitionNetImpl::feature_channels()[i]);
  }
  EXPECT_EQ(out.embedding.sizes().vec(), (std::vector<int64_t>{2, 128}));
  // Each image of a batch gets the descriptor it gets alone.
  EXPECT_LT((net->forward(images.slice(0, 1, 2))[0] - out.embedding[1]).abs().max().item<float>(), 1e-5);
  // Without the embedding: the same features, no descriptor.
  const auto trunk = net->forward_features(images, false);
  ASSERT_EQ(trunk.features.size(), out.features.size());
  EXPECT_FALSE(trunk.embedding.defined());
  EXPECT_TRUE(trunk.features.back().equal(out.features.back()));
}

TEST(FaceRecognition, GradientsMatchCentralDifferencesInDouble) {
  if (!have_weights()) GTEST_SKIP() << folder() << " missing ('make deps')";
  FaceRecognitionNet net(folder());
  torch::manual_seed(2);
  const torch::Tensor x = torch::rand({1, 3, 12, 10}, torch::kDouble).requires_grad_(true);
  const torch::Tensor w = torch::randn({1, 128}, torch::kDouble);
  auto f = [&](const torch::Tensor& in) { return (net->forward(in) * w).sum(); };
  f(x).backward();
  const torch::Tensor grad = x.grad();
  ASSERT_TRUE(grad.isfinite().all().item<bool>());
  ASSERT_GT(grad.abs().max().item<double>(), 0);
  torch::NoGradGuard no_grad;
  for (int k = 0; k < 3; ++k) {
    const torch::Tensor v = torch::randn_like(x);
    const double h = 1e-7;  // the net is piecewise linear (ReLU, max pool): small steps cross no kink
    const double numeric = (f(x + h * v).item<double>() - f(x - h * v).item<double>()) / (2 * h);
    const double analytic = (grad * v).sum().item<double>();
    EXPECT_NEAR(analytic, numeric, 1e-4 * std::max(1.0, std::abs(numeric))) << "direction " << k;
  }
}

TEST(FaceRecognition, WeightsRoundTripAndMissingTensors) {
  if (!have_weights()) GTEST_SKIP() << folder() << " missing ('make deps')";
  FaceRecognitionNet net(folder());
  auto weights = net->tfjs_weights();
  EXPECT_EQ(weights.size(), 4u * 29 + 1);  // conv32_down + 14 residual layers × 2 convs, 4 tensors each; fc
  FaceRecognitionNet copy(weights, "copy");
  torch::NoGradGuard no_grad;
  const torch::Tensor x = torch::rand({1, 3, 150, 150});
  EXPECT_TRUE(net->forward(x).equal(copy->forward(x)));

  weights.erase("conv128_1/conv2/scale/biases");
  try {
    FaceRecognitionNet broken(weights, "broken.safetensors");
    FAIL() << "no error for a missing tensor";
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("broken.safetensors"), std::string::npos) << what;
    EXPECT_NE(what.find("conv128_1/conv2/scale/biases"), std::string::npos) << what;
  }
  EXPECT_THROW(FaceRecognitionNet(testing::temp_dir()), IoError);
}

}  // namespace
}  // namespace bareskin::detect
