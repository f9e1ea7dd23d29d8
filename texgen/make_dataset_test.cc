// texgen make-dataset, geometry side: merging views by confidence on a hand-computed case, and the unwrap of renders
// through the true geometry (a fit equal to the truth) giving the texture back, while a fit 3 mm off does not.
// The joint landmark fit of the three views against the truth of a synthetic head, beside independent fits, and its
// reweighted refits against slipped landmarks.
// Determinism, resume and bad input run through the command (tests/cli/texgen_dataset.sh).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/test_util.h"
#include "morphable/coefficients.h"
#include "render/shade.h"
#include "template/template_face.h"
#include "texgen/member_quantize.h"
#include "fitting/multiview_fit.h"
#include "fitting/silhouette_fit.h"
#include "render/rasterize.h"
#include "texgen/texture_sample.h"
#include "fitting/view_alignment.h"
#include "fitting/view_calibration.h"

namespace bareskin::texgen {
namespace {

UnwarpResult uv_of(int size, std::vector<std::array<float, 3>> colours, std::vector<float> confidences) {
  UnwarpResult r;
  r.colour = Image(size, size, 3);
  r.confidence = Image(size, size, 1, ColorSpace::Data);
  for (size_t i = 0; i < confidences.size(); ++i) {
    for (int k = 0; k < 3; ++k) r.colour.pixels[3 * i + size_t(k)] = colours[i][size_t(k)];
    r.confidence.pixels[i] = confidences[i];
  }
  return r;
}

TEST(MergeByConfidence, WeighsViewsByConfidenceToTheSharpness) {
  // Texel 0: both views (weights 0.5² and 1²); texel 1: only the first; texel 2: only the second; texel 3: none.
  const UnwarpResult a = uv_of(2, {{1, 0, 0}, {0.2f, 0.4f, 0.6f}, {9, 9, 9}, {0, 0, 0}}, {0.5f, 0.3f, 0, 0});
  const UnwarpResult b = uv_of(2, {{0, 0, 1}, {7, 7, 7}, {0.1f, 0.1f, 0.1f}, {0, 0, 0}}, {1.0f, 0, 0.8f, 0});
  const MergedUnwrap m = merge_by_confidence({&a, &b}, 2.0);
  const float expect[4][3] = {{0.25f / 1.25f, 0, 1 / 1.25f}, {0.2f, 0.4f, 0.6f}, {0.1f, 0.1f, 0.1f}, {0, 0, 0}};
  const float confidence[4] = {1.0f, 0.3f, 0.8f, 0};
  for (int i = 0; i < 4; ++i) {
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(m.colour.pixels[size_t(3 * i + k)], expect[i][k], 1e-6) << i << " " << k;
    EXPECT_FLOAT_EQ(m.confidence.pixels[size_t(i)], confidence[i]);
  }
  // Sharpness 0: a plain mean of the views that saw the texel.
  const MergedUnwrap mean = merge_by_confidence({&a, &b}, 0.0);
  EXPECT_NEAR(mean.colour.pixels[0], 0.5f, 1e-6);
  EXPECT_NEAR(mean.colour.pixels[2], 0.5f, 1e-6);
  const UnwarpResult small = uv_of(1, {{0, 0, 0}}, {1});
  EXPECT_THROW(merge_by_confidence({&a, &small}, 2.0), InvalidInput);
}

// A smooth texture with detail at several scales (linear RGB).
Image pattern(int size) {
  Image t(size, size, 3);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double u = (x + 0.5) / size, v = (y + 0.5) / size;
      t.at(x, y, 0) = float(0.45 + 0.25 * std::sin(9 * u) * std::cos(7 * v));
      t.at(x, y, 1) = float(0.35 + 0.2 * std::sin(23 * u + 5 * v));
      t.at(x, y, 2) = float(0.3 + 0.15 * std::cos(17 * v - 3 * u));
    }
  return t;
}

// Renders the template face (textured) from the three views and unwraps each through `fitted` (the geometry the
// fit believes in, in the model frame), merged; the PSNR against the texture over the seen texels.
double merged_psnr(const Mesh& truth, const Mesh& fitted, const Image& texture, double* coverage) {
  const int render = 512, uv = 128;
  std::vector<UnwarpResult> views;
  for (const ViewSpec& view : TextureSampleOptions().views) {
    Mesh turned = truth, fit_turned = fitted;
    turned.V = (truth.V * view_rotation(view).transpose()).eval();
    fit_turned.V = (fitted.V * view_rotation(view).transpose()).eval();
    const Camera camera = view_camera("front", render, Eigen::Vector3d::Zero(), 1000);
    ShadeOptions shade;
    shade.texture = &texture;
    const Frame frame = render_frame(turned, camera, shade);
    UnwarpOptions options;
    options.size = uv;
    views.push_back(unwarp(frame.albedo, fit_turned, camera, options));
  }
  const MergedUnwrap m = merge_by_confidence({&views[0], &views[1], &views[2]}, 4);
  int64_t seen = 0;
  for (float c : m.confidence.pixels) seen += c > 0;
  *coverage = double(seen) / double(views[0].in_layout);
  return masked_psnr_srgb(m.colour, resize_square(texture, uv), m.confidence);
}

TEST(Unwrap, TruthFitGivesTheTextureBackAndAnOffsetFitDoesNot) {
  Mesh face = read_mesh(BARESKIN_TEMPLATE_DIR + "/face.obj");
  face.V = (face.V.rowwise() - 0.5 * (face.V.colwise().minCoeff() + face.V.colwise().maxCoeff())).eval();
  const Image texture = pattern(512);
  double coverage = 0;
  const double truth_psnr = merged_psnr(face, face, texture, &coverage);
  EXPECT_GT(truth_psnr, 33.0);
  EXPECT_GT(coverage, 0.9);
  Mesh off = face;
  off.V.col(0).array() += 3.0;  // the fit 3 mm to the side
  const double off_psnr = merged_psnr(face, off, texture, &coverage);
  EXPECT_LT(off_psnr, truth_psnr - 6.0) << "truth " << truth_psnr;
  std::printf("merged unwrap PSNR: truth fit %.1f dB, 3 mm off %.1f dB\n", truth_psnr, off_psnr);
}

TEST(ResizeSquare, BoxFilterAveragesAndBilinearKeepsConstants) {
  Image a(4, 4, 1, ColorSpace::Data);
  for (int i = 0; i < 16; ++i) a.pixels[size_t(i)] = float(i);
  const Image half = resize_square(a, 2);
  EXPECT_FLOAT_EQ(half.at(0, 0), (0 + 1 + 4 + 5) / 4.f);
  EXPECT_FLOAT_EQ(half.at(1, 1), (10 + 11 + 14 + 15) / 4.f);
  const Image up = resize_square(Image(3, 3, 3, ColorSpace::Linear, 0.25f), 7);
  for (float v : up.pixels) EXPECT_FLOAT_EQ(v, 0.25f);
}

TEST(SampleLight, DefaultFirstThenSeededRandomLights) {
  EXPECT_EQ(sample_light(0, 5), default_lighting());
  EXPECT_EQ(sample_light(2, 5), sample_light(2, 5));
  EXPECT_NE(sample_light(2, 5), sample_light(2, 6));
  EXPECT_NE(sample_light(1, 5), sample_light(2, 5));
}

// A model on the test template whose identity components change what one frontal view cannot see well: the depth
// of the face's centre (nose and lips forward), its width, and the chin's height; two expression components.
MorphableModel depth_model() {
  const TemplateFace t = read_template(BARESKIN_TEMPLATE_DIR + "/face.obj", BARESKIN_TEMPLATE_DIR + "/landmarks.json");
  MorphableModel m;
  m.topology = t.mesh;
  m.topology.V = (t.mesh.V.rowwise() - 0.5 * (t.mesh.V.colwise().minCoeff() + t.mesh.V.colwise().maxCoeff())).eval();
  m.landmark_vertices = t.landmark_vertices;
  const int V = m.vertices();
  m.shape_basis = RowMatrixXf::Zero(3, 3 * V);
  m.expression_basis = RowMatrixXf::Zero(2, 3 * V);
  for (int v = 0; v < V; ++v) {
    const Eigen::Vector3d p = m.topology.V.row(v);
    const double centre = std::exp(-(p.x() * p.x() + p.y() * p.y()) / (2 * 30.0 * 30.0));
    m.shape_basis(0, 3 * v + 2) = float(centre);
    m.shape_basis(1, 3 * v) = float(p.x() / 50);
    m.shape_basis(2, 3 * v + 1) = float(std::min(0.0, p.y()) / 50);
    m.expression_basis(0, 3 * v + 1) = float(std::min(0.0, p.y() + 30) / 50);
    m.expression_basis(1, 3 * v) = float(p.y() / 80);
  }
  for (RowMatrixXf* b : {&m.shape_basis, &m.expression_basis})
    for (int k = 0; k < b->rows(); ++k) b->row(k).normalize();
  m.shape_stddev = Eigen::Vector3f(150, 120, 120);  // per unit basis row: a few mm at the landmarks
  m.expression_stddev = Eigen::Vector2f(100, 80);
  return m;
}

// The three views' landmarks of a known head (the model at alpha, beta, slightly posed) with detector-like noise: one
// fit to all three views finds the shape closer to the truth than three independent fits do, and without noise it
// finds it exactly and reproduces every view's landmarks.
TEST(MultiviewFit, JointFitOfTheThreeViewsBeatsIndependentFits) {
  const MorphableModel model = depth_model();
  const Eigen::VectorXd alpha = Eigen::Vector3d(2.0, -1.0, 1.5), beta = Eigen::Vector2d(0.5, -0.5);
  const Eigen::Vector3d rotation(0.05, -0.03, 0.02), translation(2, -3, 5);
  const Eigen::MatrixX3d truth = model.shape(alpha, beta);
  const int size = 1024;
  const Camera camera = view_camera("front", size, Eigen::Vector3d::Zero(), 1000);
  const auto views_with_noise = [&](double sigma_px, uint64_t seed) {
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> noise(0, sigma_px);
    std::vector<LandmarkViewInput> views;
    for (const ViewSpec& view : TextureSampleOptions().views) {
      LandmarkViewInput v;
      v.rotation = view_rotation(view);
      for (int k = 0; k < 68; ++k) {
        const Eigen::Vector3d p = v.rotation * (euler_rotation(rotation) * truth.row(model.landmark_vertices[size_t(k)]).transpose() + translation);
        const Eigen::Vector3d q = camera.project(p);
        v.landmarks.row(k) << q.x() + noise(rng), q.y() + noise(rng);
      }
      views.push_back(v);
    }
    return views;
  };
  LandmarkFitOptions options;
  options.shape_components = 3;
  options.expression_components = 2;
  const auto shape_error = [&](const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
    return (model.shape(a, b) - truth).rowwise().norm().mean();
  };
  // Noise-free: the joint fit is exact, and each view's coefficients reproduce that view's landmarks.
  const std::vector<LandmarkViewInput> clean = views_with_noise(0, 1);
  const MultiviewLandmarkFit exact = fit_landmarks_multiview(model, clean, camera, options, false);
  EXPECT_LT(shape_error(exact.alpha, exact.beta), 0.05);
  for (size_t v = 0; v < clean.size(); ++v) {
    const Mesh posed = posed_mesh(model, view_coefficients(exact, v));
    double worst = 0;
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d q = camera.project(posed.V.row(model.landmark_vertices[size_t(k)]).transpose());
      worst = std::max(worst, (Eigen::Vector2d(q.x(), q.y()) - clean[v].landmarks.row(k).transpose()).norm());
    }
    EXPECT_LT(worst, 0.05) << "view " << v;
  }
  // With 8 px of noise per point (face-api's error on renders is 3x that): the joint fit's shape error, averaged
  // over a few draws, is below the independent fits' (each view alone, as make-dataset did before).
  double joint = 0, shared = 0, independent = 0;
  const int draws = 6;
  for (int d = 0; d < draws; ++d) {
    const std::vector<LandmarkViewInput> noisy = views_with_noise(8, 100 + uint64_t(d));
    const MultiviewLandmarkFit j = fit_landmarks_multiview(model, noisy, camera, options, false);
    joint += shape_error(j.alpha, j.beta) / draws;
    const MultiviewLandmarkFit js = fit_landmarks_multiview(model, noisy, camera, options, true);
    shared += shape_error(js.alpha, js.beta) / draws;
    for (const LandmarkViewInput& v : noisy) {
      const LandmarkFit one = fit_landmarks(model, v.landmarks, camera, options);
      independent += shape_error(one.alpha, one.beta) / (draws * double(noisy.size()));
    }
  }
  EXPECT_LT(joint, 0.8 * independent) << "joint " << joint << " mm, independent " << independent << " mm";
  EXPECT_LT(shared, 0.8 * independent) << "shared shape " << shared << " mm, independent " << independent << " mm";
  std::printf("shape error with 8 px landmark noise: rigid joint fit %.2f mm, shared shape with a pose per view %.2f mm, "
              "independent fits %.2f mm\n", joint, shared, independent);

  // Detector slips: 4 px noise, and in each draw 8 landmarks of one view moved 60 px. The reweighted refits find them
  // (their weights fall below 0.2 while the clean points keep more than 0.5) and the shape error falls below the plain
  // fit's; with clean input, reweighting changes nothing that matters.
  double plain = 0, robust = 0;
  for (int d = 0; d < draws; ++d) {
    std::vector<LandmarkViewInput> slipped = views_with_noise(4, 200 + uint64_t(d));
    std::mt19937_64 rng(300 + uint64_t(d));
    const size_t view = size_t(d) % slipped.size();
    std::vector<int> moved;
    while (moved.size() < 8) {
      const int k = int(rng() % 68);
      if (std::find(moved.begin(), moved.end(), k) == moved.end()) moved.push_back(k);
    }
    for (int k : moved) slipped[view].landmarks.row(k) += Eigen::RowVector2d(60 * std::cos(k), 60 * std::sin(k));
    const MultiviewLandmarkFit p = fit_landmarks_multiview(model, slipped, camera, options, true);
    const MultiviewLandmarkFit r = fit_landmarks_multiview_robust(model, slipped, camera, options, true, nullptr, 3);
    plain += shape_error(p.alpha, p.beta) / draws;
    robust += shape_error(r.alpha, r.beta) / draws;
    for (int k = 0; k < 68; ++k) {
      const bool slip = std::find(moved.begin(), moved.end(), k) != moved.end();
      if (slip) EXPECT_LT(r.weight(Eigen::Index(view), k), 0.2) << "draw " << d << " landmark " << k;
      else EXPECT_GT(r.weight(Eigen::Index(view), k), 0.5) << "draw " << d << " landmark " << k;
    }
  }
  EXPECT_LT(robust, 0.5 * plain) << "robust " << robust << " mm, plain " << plain << " mm";
  const MultiviewLandmarkFit clean_robust = fit_landmarks_multiview_robust(model, clean, camera, options, true, nullptr, 3);
  EXPECT_LT(shape_error(clean_robust.alpha, clean_robust.beta), 0.05);
  std::printf("shape error with 8 slipped landmarks (60 px) in one view: plain %.2f mm, reweighted %.2f mm\n", plain, robust);
}

// The signed distance against brute force on a small mask with two blobs and a hole.
TEST(Silhouette, SignedDistanceMatchesBruteForce) {
  const int S = 40;
  std::vector<uint8_t> mask(size_t(S * S), 0);
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      const double a = std::hypot(x - 12, y - 15), b = std::hypot(x - 29, y - 26);
      mask[size_t(y * S + x)] = (a < 9 && a > 3) || (std::abs(x - 29) < 6 && std::abs(y - 26) < 4) || b < 3;
    }
  const std::vector<float> sdf = signed_distance(mask, S);
  double worst = 0;
  for (int y = 0; y < S; ++y)
    for (int x = 0; x < S; ++x) {
      double best = 1e9;
      for (int v = 0; v < S; ++v)
        for (int u = 0; u < S; ++u)
          if (mask[size_t(v * S + u)] != mask[size_t(y * S + x)]) best = std::min(best, std::hypot(u - x, v - y));
      const double expect = (mask[size_t(y * S + x)] ? -1 : 1) * (best - 0.5);
      worst = std::max(worst, std::abs(sdf[size_t(y * S + x)] - expect));
    }
  EXPECT_LT(worst, 1e-4);
  // The region of a render on black: its hole (dark skin) stays in, the background joined to the border does not.
  Image render(S, S, 3, ColorSpace::sRGB);
  for (size_t i = 0; i < mask.size(); ++i)
    for (int c = 0; c < 3; ++c) render.pixels[3 * i + size_t(c)] = mask[i] ? 0.5f : 0.f;
  const std::vector<uint8_t> region = face_silhouette(render);
  EXPECT_EQ(region[size_t(15 * S + 12)], 1);  // the hole of the ring
  EXPECT_EQ(region[size_t(2 * S + 2)], 0);
  EXPECT_EQ(region[size_t(15 * S + 5)], 1);
}

// The three views of a known head, as make-dataset's renders (the head on black) and landmarks with 8 px of noise:
// the silhouette term brings the shared-shape fit's shape closer to the truth.
TEST(Silhouette, OutlinesBringTheShapeCloserToTheTruth) {
  const MorphableModel model = depth_model();
  const Eigen::VectorXd alpha = Eigen::Vector3d(2.0, -1.0, 1.5), beta = Eigen::Vector2d(0.5, -0.5);
  const Eigen::Vector3d rotation(0.05, -0.03, 0.02), translation(2, -3, 5);
  const Eigen::MatrixX3d truth = model.shape(alpha, beta);
  const int size = 512;
  const Camera camera = view_camera("front", size, Eigen::Vector3d::Zero(), 1000);
  LandmarkFitOptions options;
  options.shape_components = 3;
  options.expression_components = 2;
  const auto shape_error = [&](const MultiviewLandmarkFit& f) {
    return (model.shape(f.alpha, f.beta) - truth).rowwise().norm().mean();
  };
  double plain = 0, outlined = 0;
  const int draws = 4;
  for (int d = 0; d < draws; ++d) {
    std::mt19937_64 rng(400 + uint64_t(d));
    std::normal_distribution<double> noise(0, 8 * size / 1024.0);
    std::vector<LandmarkViewInput> views;
    std::vector<Image> renders;
    for (const ViewSpec& view : TextureSampleOptions().views) {
      LandmarkViewInput v;
      v.rotation = view_rotation(view);
      Mesh head = model.topology;
      head.V = (((truth * euler_rotation(rotation).transpose()).rowwise() + translation.transpose()) *
                v.rotation.transpose()).eval();
      for (int k = 0; k < 68; ++k) {
        const Eigen::Vector3d q = camera.project(head.V.row(model.landmark_vertices[size_t(k)]).transpose());
        v.landmarks.row(k) << q.x() + noise(rng), q.y() + noise(rng);
      }
      const RasterOutput raster = rasterize_mesh(head, camera);
      Image render(size, size, 3, ColorSpace::sRGB);
      for (size_t i = 0; i < raster.triangle.size(); ++i)
        if (raster.triangle[i] >= 0)
          for (int c = 0; c < 3; ++c) render.pixels[3 * i + size_t(c)] = 0.6f;
      views.push_back(v);
      renders.push_back(std::move(render));
    }
    const MultiviewLandmarkFit start = fit_landmarks_multiview(model, views, camera, options, true);
    SilhouetteFitOptions silhouette;
    silhouette.rounds = 2;
    const MultiviewLandmarkFit refined = refine_with_silhouettes(
        model, views, {&renders[0], &renders[1], &renders[2]}, camera, options, nullptr, start, silhouette, false);
    plain += shape_error(start) / draws;
    outlined += shape_error(refined) / draws;
  }
  EXPECT_LT(outlined, 0.7 * plain) << "with silhouettes " << outlined << " mm, landmarks only " << plain << " mm";
  std::printf("shape error with 8 px landmark noise: landmarks only %.2f mm, with the silhouettes %.2f mm\n", plain,
              outlined);
}

TEST(MultiviewFit, EulerAnglesInvertTheRotation) {
  for (const Eigen::Vector3d& a : {Eigen::Vector3d(0.1, -0.4, 0.3), Eigen::Vector3d(-1.2, 0.9, 2.5), Eigen::Vector3d(0, 0, 0)})
    EXPECT_LT((euler_angles(euler_rotation(a)) - a).norm(), 1e-12) << a.transpose();
}

// The members' 8-bit table against its formula: random floats over [0, 1] (uniform in value and in bit pattern), the
// floats next to every threshold, and the ends.
TEST(MemberQuantizer, TableMatchesTheFormula) {
  std::mt19937 rng(5);
  for (const bool srgb : {true, false}) {
    const MemberQuantizer& q = srgb ? MemberQuantizer::colour() : MemberQuantizer::data();
    std::vector<float> values = {0.f, -1.f, 1.f, 2.f, std::nanf(""), 1e-30f, 0.0031308f, 0.5f / 255, 254.5f / 255};
    std::uniform_real_distribution<float> unit(0.f, 1.f);
    std::uniform_int_distribution<uint32_t> pattern(0, 0x3F800000u);
    for (int i = 0; i < 200000; ++i) {
      values.push_back(unit(rng));
      const uint32_t u = pattern(rng);
      float v;
      std::memcpy(&v, &u, sizeof(v));
      values.push_back(v);
    }
    for (int k = 0; k < 256; ++k)  // around each step of the output: where the table's thresholds must sit
      for (float centre : {(k + 0.5f) / 255.f, srgb ? srgb_to_linear((k + 0.5f) / 255.f) : 0.f}) {
        float up = centre, down = centre;
        for (int n = 0; n < 64; ++n) {
          values.push_back(up = std::nextafter(up, 2.f));
          values.push_back(down = std::nextafter(down, -1.f));
        }
      }
    int64_t wrong = 0;
    for (float v : values) wrong += q(v) != MemberQuantizer::direct(v, srgb);
    EXPECT_EQ(wrong, 0) << "srgb " << srgb << " over " << values.size() << " values";
    EXPECT_EQ(q(0.5f), srgb ? 188 : 128);  // linear 0.5 is sRGB 0.7354 → 188 (187.5 rounds up)
  }
}

}  // namespace
}  // namespace bareskin::texgen

namespace bareskin::texgen {
namespace {

// The three views' true coefficients (shape alpha, expression 0, the views' rig poses) and the test face's textured
// renders under them.
struct RenderedViews {
  std::vector<Coefficients> truth;
  std::vector<Image> images;
  std::vector<const Image*> pointers() const {
    std::vector<const Image*> p;
    for (const Image& img : images) p.push_back(&img);
    return p;
  }
};
RenderedViews render_views(const MorphableModel& model, const Image& texture, const Camera& camera,
                           const Eigen::VectorXd& alpha) {
  RenderedViews r;
  for (const ViewSpec& view : TextureSampleOptions().views) {
    Coefficients c;
    c.alpha = alpha;
    c.beta = Eigen::VectorXd::Zero(2);
    c.rotation = euler_angles(view_rotation(view));
    c.translation = Eigen::Vector3d::Zero();
    ShadeOptions shade;
    shade.texture = &texture;
    r.images.push_back(render_frame(posed_mesh(model, c), camera, shade).albedo);
    r.truth.push_back(c);
  }
  return r;
}

// Photometric view alignment against the truth: the test face (textured) rendered from the three views at known
// poses; the side views' poses are then knocked off by a few degrees and millimetres (as face-api's scatter moves
// them). Aligning their unwraps to the front's brings their landmarks' projections back within a fraction of the
// offset, and the merged unwrap's PSNR against the texture rises.
TEST(ViewAlignment, SideViewsReturnToTheirTruePoses) {
  const MorphableModel model = depth_model();
  const Image texture = pattern(256);
  const int size = 256;
  const Camera camera = view_camera("front", size, Eigen::Vector3d::Zero(), 1000);
  const RenderedViews rendered = render_views(model, texture, camera, Eigen::VectorXd::Zero(3));
  const std::vector<Coefficients>& truth = rendered.truth;
  const std::vector<Image>& images = rendered.images;
  const Eigen::Vector3d knocks[3][2] = {{{0, 0, 0}, {0, 0, 0}},
                                        {{0.02, 0.05, -0.02}, {3, -2, 4}},
                                        {{-0.03, -0.04, 0.015}, {-2, 3, -3}}};
  std::vector<Coefficients> knocked = truth;
  for (size_t v = 0; v < knocked.size(); ++v) {
    knocked[v].rotation += knocks[v][0];
    knocked[v].translation += knocks[v][1];
  }
  // Mean distance (px) between the landmark vertices' projections under two poses of the same view.
  const auto landmark_px = [&](const Coefficients& a, const Coefficients& b) {
    const Mesh pa = posed_mesh(model, a), pb = posed_mesh(model, b);
    double sum = 0;
    for (int k : model.landmark_vertices) {
      const Eigen::Vector3d qa = camera.project(pa.V.row(k).transpose()), qb = camera.project(pb.V.row(k).transpose());
      sum += (qa - qb).head<2>().norm();
    }
    return sum / double(model.landmark_vertices.size());
  };
  const auto merged_psnr_of = [&](const std::vector<Coefficients>& views) {
    std::vector<UnwarpResult> unwraps;
    UnwarpOptions o;
    o.size = 128;
    for (size_t i = 0; i < views.size(); ++i) unwraps.push_back(unwarp(images[i], posed_mesh(model, views[i]), camera, o));
    const MergedUnwrap m = merge_by_confidence({&unwraps[0], &unwraps[1], &unwraps[2]}, 4);
    return masked_psnr_srgb(m.colour, resize_square(texture, 128), m.confidence);
  };
  ViewAlignmentOptions options;
  options.rounds = 2;
  options.size = 256;
  const std::vector<const Image*> pointers = rendered.pointers();
  const ViewAlignment aligned = align_views_photometric(model, knocked, pointers, camera, options);
  EXPECT_EQ(landmark_px(aligned.views[0], truth[0]), 0.0);  // the front keeps its pose
  for (int i = 1; i < 3; ++i) {
    const double before = landmark_px(knocked[size_t(i)], truth[size_t(i)]);
    const double after = landmark_px(aligned.views[size_t(i)], truth[size_t(i)]);
    EXPECT_GT(before, 3.0) << "view " << i;
    EXPECT_LT(after, 0.25 * before) << "view " << i << ": " << before << " px -> " << after << " px";
    EXPECT_LT(aligned.rms_after[size_t(i)], aligned.rms_before[size_t(i)]);
    std::printf("view %d: landmarks %.2f px off -> %.2f px\n", i, before, after);
  }
  // With the true landmarks holding the poses (the anchor term), the side views also come back.
  std::vector<LandmarkViewInput> landmarks(3);
  for (size_t i = 0; i < 3; ++i) {
    const Mesh posed = posed_mesh(model, truth[i]);
    for (int k = 0; k < 68; ++k)
      landmarks[i].landmarks.row(k) = camera.project(posed.V.row(model.landmark_vertices[size_t(k)]).transpose()).head<2>().transpose();
  }
  options.landmark_weight = 10;
  const ViewAlignment anchored = align_views_photometric(model, knocked, pointers, camera, options, landmarks);
  for (size_t i = 1; i < 3; ++i)
    EXPECT_LT(landmark_px(anchored.views[i], truth[i]), 0.25 * landmark_px(knocked[i], truth[i])) << "anchored view " << i;
  const double psnr_before = merged_psnr_of(knocked), psnr_after = merged_psnr_of(aligned.views);
  EXPECT_GT(psnr_after, psnr_before + 3) << psnr_before << " -> " << psnr_after;
  std::printf("merged unwrap PSNR %.1f -> %.1f dB (truth poses %.1f dB)\n", psnr_before, psnr_after, merged_psnr_of(truth));
}

// The shape too (options.shape): the test face rendered with a shape α ≠ 0 from the three views at their true
// poses; fitted from the mean shape (α = 0) with the side views knocked off, the joint alignment brings the shape's
// vertices closer to the truth's.
TEST(ViewAlignment, SharedShapeMovesTowardTheTruth) {
  const MorphableModel model = depth_model();
  const Image texture = pattern(256);
  const Camera camera = view_camera("front", 256, Eigen::Vector3d::Zero(), 1000);
  Eigen::VectorXd alpha_true(3);
  alpha_true << 1.5, -1.0, 1.0;
  const RenderedViews rendered = render_views(model, texture, camera, alpha_true);
  std::vector<Coefficients> start = rendered.truth;
  for (size_t v = 0; v < start.size(); ++v) {
    start[v].alpha = Eigen::VectorXd::Zero(3);
    if (v > 0) start[v].translation += Eigen::Vector3d(v == 1 ? 2 : -2, 1, 0);
  }
  const std::vector<const Image*> pointers = rendered.pointers();
  ViewAlignmentOptions options;
  options.rounds = 2;
  options.shape = true;
  options.shape_prior = 0.01;
  options.size = 128;
  const ViewAlignment aligned = align_views_photometric(model, start, pointers, camera, options);
  const Eigen::MatrixX3d truth = model.shape(alpha_true, Eigen::VectorXd::Zero(2));
  const auto error_mm = [&](const Eigen::VectorXd& a) {
    return (model.shape(a, Eigen::VectorXd::Zero(2)) - truth).rowwise().norm().mean();
  };
  const double before = error_mm(start[0].alpha), after = error_mm(aligned.views[0].alpha);
  EXPECT_GT(before, 0.5);
  EXPECT_LT(after, 0.5 * before) << before << " mm -> " << after << " mm";
  for (size_t i = 1; i < 3; ++i) EXPECT_EQ(aligned.views[i].alpha, aligned.views[0].alpha);
  std::printf("shape %.2f mm -> %.2f mm from the truth\n", before, after);
}

// Per-view calibration: a detector whose error is a fixed pattern per view (the same for every subject) plus scatter.
// Learned from six training subjects' reports, the pattern comes back within the scatter's share, survives the file,
// and subtracting it from a new subject's landmarks brings the shared-shape fit much closer to its shape.
TEST(ViewCalibration, LearnsEachViewsBiasAndTheFitGetsCloser) {
  const MorphableModel model = depth_model();
  const int size = 1024;
  const Camera camera = view_camera("front", size, Eigen::Vector3d::Zero(), 1000);
  const std::vector<ViewSpec> views = TextureSampleOptions().views;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0, 2), coefficient(0, 1);
  const auto subject_at = [&](const Eigen::VectorXd& alpha) {
    Subject s;
    s.mesh = model.topology;
    s.mesh.V = model.shape(alpha, Eigen::VectorXd::Zero(2));
    return s;
  };
  // The detector's bias per view: the mean face's landmarks stretched about their centre (by +8 %, −6 %, +5 % across,
  // −4 %, +6 %, 0 % down) and shifted: a wrong width and height that a shape fit takes up, different in each view.
  std::vector<Landmarks68> bias(views.size());
  const double stretch[3][2] = {{0.08, -0.04}, {-0.06, 0.06}, {0.05, 0}};
  for (size_t v = 0; v < views.size(); ++v) {
    const Landmarks68 mean = true_landmarks(model, subject_at(Eigen::VectorXd::Zero(3)), views[v], camera, nullptr);
    const Eigen::RowVector2d centre = mean.colwise().mean();
    for (int k = 0; k < 68; ++k)
      bias[v].row(k) = (mean.row(k) - centre).cwiseProduct(Eigen::RowVector2d(stretch[v][0], stretch[v][1])) +
                       Eigen::RowVector2d(3 - 3 * double(v), 2);
  }
  const auto bias_px = [&](size_t v, int k) { return Eigen::RowVector2d(bias[v].row(k)); };
  const auto detected = [&](const Landmarks68& truth, size_t v) {
    Landmarks68 d = truth;
    for (int k = 0; k < 68; ++k) d.row(k) += bias_px(v, k) + Eigen::RowVector2d(noise(rng), noise(rng));
    return d;
  };
  const auto points = [](const Landmarks68& p) {
    nlohmann::json j = nlohmann::json::array();
    for (int k = 0; k < 68; ++k) j.push_back({p(k, 0), p(k, 1)});
    return j;
  };
  // The truth: the subject's landmark vertices as the posed shape puts them in each view.
  const Subject check = subject_at(Eigen::Vector3d(1, -1, 0.5));
  for (const ViewSpec& view : views) {
    Coefficients c;
    c.alpha = Eigen::Vector3d(1, -1, 0.5);
    c.beta = Eigen::VectorXd::Zero(2);
    c.rotation = euler_angles(view_rotation(view));
    c.translation.setZero();
    const Mesh posed = posed_mesh(model, c);
    const Landmarks68 t = true_landmarks(model, check, view, camera, nullptr);
    for (int k = 0; k < 68; ++k)
      EXPECT_LT((camera.project(posed.V.row(model.landmark_vertices[size_t(k)]).transpose()).head<2>().transpose() -
                 t.row(k)).norm(), 1e-6);
  }
  // Six training subjects' reports (the fields make-dataset writes).
  const std::string dir = testing::temp_dir();
  std::vector<std::string> files;
  for (int s = 0; s < 6; ++s) {
    const Subject subject = subject_at(Eigen::Vector3d(coefficient(rng), coefficient(rng), coefficient(rng)));
    nlohmann::json vj = nlohmann::json::array();
    for (size_t v = 0; v < views.size(); ++v) {
      const Landmarks68 t = true_landmarks(model, subject, views[v], camera, nullptr);
      vj.push_back({{"name", views[v].name}, {"yaw_deg", views[v].yaw_deg},
                    {"landmarks_detected_px", points(detected(t, v))}, {"landmarks_truth_px", points(t)}});
    }
    const nlohmann::json report = {{"subject", "s" + std::to_string(s)},
                                   {"lights", {{{"landmark_calibration", ""}, {"sizes", {{"render", size}}}, {"views", vj}}}}};
    files.push_back(dir + "/s" + std::to_string(s) + ".json");
    write_file_atomic(files.back(), report.dump());
  }
  const ViewCalibration learned = learn_view_calibration(files);
  ASSERT_EQ(learned.views.size(), views.size());
  for (size_t v = 0; v < views.size(); ++v) {
    const ViewCalibration::View& c = learned.at(views[v].name, views[v].yaw_deg, "test");
    EXPECT_EQ(c.samples, 6);
    double error = 0, scatter = 0;
    for (int k = 0; k < 68; ++k) {
      error += (c.bias.row(k) * size - bias_px(v, k)).norm() / 68;
      scatter += c.scatter(k) * size / 68;
    }
    EXPECT_LT(error, 1.5) << views[v].name;  // 2 px scatter / sqrt(6) per axis
    EXPECT_GT(scatter, 1.5) << views[v].name;  // sqrt(5/6) · 2 sqrt(2) px expected
    EXPECT_LT(scatter, 3.5) << views[v].name;
  }
  EXPECT_THROW(learned.at("front", 10, "test"), InvalidInput);
  EXPECT_THROW(learned.at("top", 0, "test"), InvalidInput);
  write_view_calibration(dir + "/view.json", learned);
  const ViewCalibration read = read_view_calibration(dir + "/view.json");
  ASSERT_EQ(read.views.size(), learned.views.size());
  for (size_t v = 0; v < read.views.size(); ++v) EXPECT_EQ(read.views[v].bias, learned.views[v].bias);
  EXPECT_THROW(read_view_calibration(files[0]), InvalidInput);
  // Reports without the landmarks, or made with two different 3D calibrations, are refused.
  write_file_atomic(dir + "/old.json", R"({"lights": [{"sizes": {"render": 1024}, "views": [{"name": "front", "yaw_deg": 0}]}]})");
  EXPECT_THROW(learn_view_calibration({files[0], dir + "/old.json"}), InvalidInput);
  nlohmann::json other = nlohmann::json::parse(read_file(files[1]));
  other["lights"][0]["landmark_calibration"] = "calib.json";
  write_file_atomic(dir + "/other.json", other.dump());
  EXPECT_THROW(learn_view_calibration({files[0], dir + "/other.json"}), InvalidInput);

  // A new subject: the shared-shape fit on its detected landmarks, raw and calibrated.
  const Eigen::VectorXd alpha_true = Eigen::Vector3d(1.5, -1.0, 1.2);
  const Subject subject = subject_at(alpha_true);
  std::vector<LandmarkViewInput> raw, calibrated;
  for (size_t v = 0; v < views.size(); ++v) {
    LandmarkViewInput in;
    in.rotation = view_rotation(views[v]);
    in.landmarks = detected(true_landmarks(model, subject, views[v], camera, nullptr), v);
    raw.push_back(in);
    in.landmarks = calibrated_landmarks(in.landmarks, read.at(views[v].name, views[v].yaw_deg, "test"), size);
    calibrated.push_back(in);
  }
  LandmarkFitOptions options;
  options.shape_components = 3;
  options.expression_components = 2;
  const auto error_mm = [&](const std::vector<LandmarkViewInput>& in) {
    const MultiviewLandmarkFit f = fit_landmarks_multiview_robust(model, in, camera, options, true, nullptr, 2);
    return (model.shape(f.alpha, f.beta) - subject.mesh.V).rowwise().norm().mean();
  };
  const double before = error_mm(raw), after = error_mm(calibrated);
  EXPECT_LT(after, 0.5 * before) << before << " mm -> " << after << " mm";
  std::printf("per-view calibration: shape %.2f mm -> %.2f mm from the truth\n", before, after);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace bareskin::texgen
