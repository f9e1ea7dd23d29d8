// Deep3DFaceRecon's 5-point alignment (detect/align.h): the standard face is the template seen by the canonical
// camera; the fit recovers a known scale + translation; the warp is exact on a linear ramp (bilinear's invariant).
#include "detect/align.h"

#include <gtest/gtest.h>

#include <random>

#include "core/error.h"
#include "core/landmarks.h"
#include "core/test_util.h"
#include "render/camera.h"

namespace bareskin::detect {
namespace {

std::vector<Eigen::Vector3d> template_landmarks() {
  const Landmarks lm = read_landmarks(BARESKIN_TEMPLATE_DIR + "/landmarks.json");
  std::vector<Eigen::Vector3d> out;
  for (int i = 0; i < lm.points.rows(); ++i) out.push_back(lm.points.row(i).transpose());
  return out;
}

// The constants were derived from the 65k template; the small test template (6k vertices, landmarks snapped to its
// own nearest vertices, edges ~3 mm = 3.5 px apart) gives the same standard face within 2 px, symmetric by
// construction.
TEST(Align, StandardFaceIsTheTemplateSeenByTheCanonicalCamera) {
  const FivePoints derived = standard_five_points_from(template_landmarks());
  EXPECT_LT((derived - standard_five_points()).cwiseAbs().maxCoeff(), 2.0) << derived;
  EXPECT_NEAR(derived(0, 0) + derived(1, 0), kAlignedSize, 1e-9);
  EXPECT_NEAR(derived(2, 0), kAlignedSize / 2.0, 1e-9);
}

// The template rendered by the canonical camera needs (almost) no alignment: aligned renders and photos agree.
TEST(Align, CanonicalRenderOfTheTemplateIsAlreadyAligned) {
  const Camera camera = view_camera("front", kAlignedSize, Eigen::Vector3d::Zero(), 1000);
  const auto points = template_landmarks();
  Landmarks68 lm;
  for (int i = 0; i < 68; ++i) lm.row(i) = camera.project(points[i]).head<2>().transpose();
  const Similarity s = alignment(lm);
  EXPECT_NEAR(s.scale, 1.0, 0.01);
  EXPECT_LT((s.apply({128, 128}) - Eigen::Vector2d(128, 128)).norm(), 1.0);
}

TEST(Align, RecoversAKnownScaleAndTranslationFromNoisyLandmarks) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0, 0.5);
  std::uniform_real_distribution<double> scale(0.3, 3), shift(-200, 200);
  const Camera camera = view_camera("front", kAlignedSize, Eigen::Vector3d::Zero(), 1000);
  const auto points = template_landmarks();
  Landmarks68 aligned;
  for (int i = 0; i < 68; ++i) aligned.row(i) = camera.project(points[i]).head<2>().transpose();
  const Similarity ideal = alignment(aligned);
  for (int trial = 0; trial < 20; ++trial) {
    Similarity truth;  // photo → aligned frame of the standard face
    truth.scale = scale(rng);
    truth.translation = {shift(rng), shift(rng)};
    Landmarks68 photo;
    for (int i = 0; i < 68; ++i) photo.row(i) = truth.inverse(aligned.row(i).transpose()).transpose();
    const Similarity exact = alignment(photo);
    // Composed with the template's own (near-identity) alignment, the fit inverts the photo's similarity exactly.
    EXPECT_NEAR(exact.scale, ideal.scale * truth.scale, 1e-9);
    const Eigen::Vector2d expect = ideal.apply(truth.translation);
    EXPECT_LT((exact.translation - expect).norm(), 1e-7);
    for (int i = 0; i < 68; ++i) photo.row(i) += Eigen::RowVector2d(noise(rng), noise(rng));
    const Similarity noisy = alignment(photo);
    EXPECT_NEAR(noisy.scale / exact.scale, 1.0, 0.03);
    EXPECT_LT((transform(noisy, photo) - transform(exact, photo)).rowwise().norm().maxCoeff(), 3.0);
  }
}

// Bilinear interpolation reproduces a linear function exactly: aligned(x) = ramp(inverse(x)) wherever the four
// neighbours are inside the photo; black where the inverse lands outside.
TEST(Align, WarpSamplesThePhotoAtTheInverseSimilarity) {
  Image photo(300, 200, 2, ColorSpace::Data);
  const auto ramp = [](double x, double y, int c) { return c == 0 ? 0.01 * x + 0.002 * y : 1 - 0.003 * y; };
  for (int y = 0; y < photo.height; ++y)
    for (int x = 0; x < photo.width; ++x)
      for (int c = 0; c < 2; ++c) photo.at(x, y, c) = float(ramp(x + 0.5, y + 0.5, c));
  Similarity s;
  s.scale = 1.37;
  s.translation = {-40.3, 12.8};
  const Image out = warp_aligned(photo, s, kAlignedSize);
  ASSERT_EQ(out.width, kAlignedSize);
  ASSERT_EQ(out.channels, 2);
  int inside = 0, outside = 0;
  for (int y = 0; y < kAlignedSize; ++y) {
    for (int x = 0; x < kAlignedSize; ++x) {
      const Eigen::Vector2d p = s.inverse({x + 0.5, y + 0.5});
      if (p.x() > 0.5 && p.y() > 0.5 && p.x() < photo.width - 0.5 && p.y() < photo.height - 0.5) {
        for (int c = 0; c < 2; ++c) ASSERT_NEAR(out.at(x, y, c), ramp(p.x(), p.y(), c), 1e-5) << x << "," << y;
        ++inside;
      } else if (p.x() < -1 || p.y() < -1 || p.x() > photo.width + 1 || p.y() > photo.height + 1) {
        ASSERT_EQ(out.at(x, y, 0), 0.f);
        ++outside;
      }
    }
  }
  EXPECT_GT(inside, 10000);
  EXPECT_GT(outside, 1000);
}

TEST(Align, DegenerateLandmarksAreRefused) {
  Landmarks68 same = Landmarks68::Constant(5.0);
  EXPECT_THROW(alignment(same), InvalidInput);
  Landmarks68 nan = Landmarks68::Zero();
  nan(30, 0) = std::nan("");
  EXPECT_THROW(alignment(nan), InvalidInput);
}

}  // namespace
}  // namespace bareskin::detect
