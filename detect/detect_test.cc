// The TensorFlow.js weight reader against hand-made manifests, face-api's preprocessing against a direct loop
// implementation of tfjs's legacy bilinear resize, and CPU/CUDA parity of both networks (GPU machine only).
// Agreement with face-api's own JavaScript is tests/cli/landmarks.sh (node oracle).
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdlib.h>

#include "core/error.h"
#include "detect/face_api.h"
#include "detect/tfjs_weights.h"

namespace bareskin::detect {
namespace {

// A fresh folder per run (no remove_all: with pip torch's build it crashed on the GPU machine's libstdc++).
std::string temp_dir(const std::string& name) {
  std::string pattern = (std::filesystem::temp_directory_path() / ("bareskin_detect_test_" + name + "_XXXXXX")).string();
  if (!mkdtemp(pattern.data())) throw std::runtime_error("mkdtemp failed");
  return pattern;
}

void write(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

// A manifest with a uint8-quantised [2, 3] tensor, a float32 [2] tensor and a float16 [1] tensor in two shards.
std::string make_manifest(const std::string& dir, size_t drop_bytes = 0, const std::string& extra = "") {
  write(dir + "/m.json", R"([{"paths": ["a.bin", "b.bin"], "weights": [
      {"name": "q", "shape": [2, 3], "dtype": "float32", "quantization": {"dtype": "uint8", "scale": 0.5, "min": -1}},
      {"name": "f", "shape": [2], "dtype": "float32"},
      {"name": "h", "shape": [1], "dtype": "float32", "quantization": {"dtype": "float16"}}]}])");
  std::string bytes = {0, 1, 2, 3, 4, char(255)};
  const float f[2] = {1.25f, -3.5f};
  bytes += std::string(reinterpret_cast<const char*>(f), 8);
  bytes += std::string("\x00\x3c", 2);  // 1.0 in half precision, little-endian
  bytes += extra;
  bytes.resize(bytes.size() - drop_bytes);
  write(dir + "/a.bin", bytes.substr(0, 7));
  write(dir + "/b.bin", bytes.substr(std::min<size_t>(7, bytes.size())));
  return dir + "/m.json";
}

TEST(TfjsWeights, DequantisesAndReshapes) {
  const auto weights = read_tfjs_weights(make_manifest(temp_dir("ok")));
  ASSERT_EQ(weights.size(), 3u);
  const torch::Tensor q = weights.at("q");
  EXPECT_EQ(q.sizes().vec(), (std::vector<int64_t>{2, 3}));
  const float expected[6] = {-1, -0.5, 0, 0.5, 1, 126.5};
  for (int i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(q.flatten()[i].item<float>(), expected[i]);
  EXPECT_FLOAT_EQ(weights.at("f")[1].item<float>(), -3.5f);
  EXPECT_FLOAT_EQ(weights.at("h")[0].item<float>(), 1.0f);
}

TEST(TfjsWeights, RejectsShardsOfTheWrongLength) {
  EXPECT_THROW(read_tfjs_weights(make_manifest(temp_dir("short"), 1)), InvalidInput);
  EXPECT_THROW(read_tfjs_weights(make_manifest(temp_dir("long"), 0, "x")), InvalidInput);
  const std::string dir = temp_dir("missing");
  const std::string manifest = make_manifest(dir);
  std::filesystem::remove(dir + "/b.bin");
  EXPECT_THROW(read_tfjs_weights(manifest), IoError);
  write(dir + "/m.json", "{not json");
  EXPECT_THROW(read_tfjs_weights(manifest), InvalidInput);
}

// tfjs's resizeBilinear (alignCorners = false, halfPixelCenters = false) written as its CPU kernel does, on an
// explicitly padded image.
torch::Tensor reference_prepare(const torch::Tensor& image, int size, bool centre, const double mean[3]) {
  const int64_t h = image.size(0), w = image.size(1), square = std::max(h, w), diff = square - std::min(h, w);
  const int64_t append = centre ? int64_t(std::round(diff * 0.5)) : diff, before = diff - append;
  torch::Tensor padded = torch::zeros({square, square, 3});
  const int64_t oy = h < w ? before : 0, ox = w < h ? before : 0;
  padded.slice(0, oy, oy + h).slice(1, ox, ox + w).copy_(image * 255);
  auto p = padded.accessor<float, 3>();
  torch::Tensor out = torch::zeros({1, 3, size, size});
  auto o = out.accessor<float, 4>();
  const double ratio = double(square) / size;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double sy = ratio * y, sx = ratio * x;
      const int64_t y0 = int64_t(std::floor(sy)), x0 = int64_t(std::floor(sx));
      const int64_t y1 = std::min<int64_t>(square - 1, int64_t(std::ceil(sy)));
      const int64_t x1 = std::min<int64_t>(square - 1, int64_t(std::ceil(sx)));
      for (int c = 0; c < 3; ++c) {
        const double top = p[y0][x0][c] + (p[y0][x1][c] - p[y0][x0][c]) * (sx - x0);
        const double bottom = p[y1][x0][c] + (p[y1][x1][c] - p[y1][x0][c]) * (sx - x0);
        o[0][c][y][x] = float((top + (bottom - top) * (sy - y0) - mean[c]) / 255);
      }
    }
  return out;
}

TEST(FaceApi, PrepareIsTfjsLegacyBilinearOnThePaddedSquare) {
  torch::manual_seed(3);
  const double mean[3] = {100, 110, 120};
  for (auto [h, w, size, centre] : {std::tuple{37, 23, 16, true}, std::tuple{23, 37, 16, true},
                                    std::tuple{30, 51, 64, false}, std::tuple{20, 20, 112, true},
                                    std::tuple{8, 5, 3, true}}) {
    const torch::Tensor image = torch::rand({h, w, 3});
    const torch::Tensor ours = FaceApi::prepare(image, size, centre, mean);
    const torch::Tensor reference = reference_prepare(image, size, centre, mean);
    EXPECT_LT((ours - reference).abs().max().item<float>(), 2e-5) << h << "x" << w << " → " << size;
  }
}

TEST(FaceApi, CudaMatchesCpu) {
  if (!torch::cuda::is_available()) GTEST_SKIP() << "no CUDA device";
  const std::string folder = default_face_api_folder();
  if (!std::filesystem::exists(folder)) GTEST_SKIP() << folder << " missing ('make deps')";
  FaceApi cpu(folder), gpu(folder);
  gpu.to(torch::kCUDA);
  // cuDNN may use TF32 on Ampere and later (10-bit mantissa): compare in full float32 here.
  const bool tf32 = at::globalContext().allowTF32CuDNN();
  at::globalContext().setAllowTF32CuDNN(false);
  torch::manual_seed(5);
  const torch::Tensor face = torch::randn({4, 3, 112, 112}), scene = torch::randn({2, 3, 416, 416});
  EXPECT_LT((cpu.landmark_net(face) - gpu.landmark_net(face.cuda()).cpu()).abs().max().item<float>(), 1e-3);
  const torch::Tensor reference = cpu.detector_net(scene);
  const float scale = reference.abs().max().item<float>();
  EXPECT_LT((reference - gpu.detector_net(scene.cuda()).cpu()).abs().max().item<float>(), 1e-4 * scale);
  at::globalContext().setAllowTF32CuDNN(tf32);
}

}  // namespace
}  // namespace bareskin::detect
