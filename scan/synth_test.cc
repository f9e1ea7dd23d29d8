#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <numeric>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/safetensors.h"
#include "scan/test_template.h"
#include "template/surface.h"
#include "scan/synth.h"

namespace bareskin {
namespace {

using testing::test_template;

TEST(Identity, DeterministicPerSeedAndDifferentAcrossSeeds) {
  const TemplateFace& face = test_template();
  const Identity a = sample_identity(face, 42), b = sample_identity(face, 42), c = sample_identity(face, 43);
  EXPECT_EQ(a.displacement, b.displacement);
  EXPECT_EQ(a.features, b.features);
  EXPECT_GT((a.displacement - c.displacement).norm(), 1.0);
}

TEST(Identity, PopulationVariesLikeFacesAndStaysMostlySymmetric) {
  const TemplateFace& face = test_template();
  const Eigen::MatrixX3d& V = face.mesh.V;
  std::vector<double> rms;
  double symmetric_share = 0;
  const int subjects = 12;
  for (int s = 0; s < subjects; ++s) {
    const Identity id = sample_identity(face, subject_seed(7, s));
    rms.push_back(std::sqrt(id.displacement.rowwise().squaredNorm().mean()));
    const double max = id.displacement.rowwise().norm().maxCoeff();
    EXPECT_LT(max, 20.0) << "subject " << s << ": faces differ by a few mm to ~1 cm, not more";
    // Symmetry: compare the displacement at a vertex with the mirrored displacement at its mirror vertex.
    double sym = 0, total = 0;
    for (Eigen::Index i = 0; i < V.rows(); i += 7) {
      Eigen::RowVector3d m = V.row(i);
      m.x() = -m.x();
      Eigen::Index j;
      (V.rowwise() - m).rowwise().squaredNorm().minCoeff(&j);
      Eigen::RowVector3d dj = id.displacement.row(j);
      dj.x() = -dj.x();
      sym += (id.displacement.row(i) - dj).squaredNorm();
      total += id.displacement.row(i).squaredNorm() + dj.squaredNorm();
    }
    symmetric_share += 1.0 - sym / total / 2.0;
  }
  const double mean_rms = std::accumulate(rms.begin(), rms.end(), 0.0) / subjects;
  EXPECT_GT(mean_rms, 1.5);
  EXPECT_LT(mean_rms, 8.0);
  EXPECT_GT(*std::max_element(rms.begin(), rms.end()) - *std::min_element(rms.begin(), rms.end()), 0.3)
      << "subjects differ in how far they are from the template";
  EXPECT_GT(symmetric_share / subjects, 0.75);
}

TEST(Identity, DeformationFoldsNoTriangle) {
  const TemplateFace& face = test_template();
  const Eigen::MatrixX3d before = face_normals(face.mesh.V, face.mesh.F);
  for (int s = 0; s < 6; ++s) {
    const Eigen::MatrixX3d after = face_normals(face.mesh.V + sample_identity(face, subject_seed(3, s)).displacement, face.mesh.F);
    int folded = 0;
    for (Eigen::Index f = 0; f < before.rows(); ++f) folded += before.row(f).dot(after.row(f)) < 0.2;
    EXPECT_EQ(folded, 0) << "subject " << s;
  }
}

TEST(SynthScan, TruthLiesOnTheScanAndLandmarksFollowIt) {
  const TemplateFace& face = test_template();
  SynthOptions opt;
  opt.scan_vertices = 8000;
  const SyntheticScan scan = synthesize_scan(face, 0, opt);
  EXPECT_NEAR(double(scan.mesh.V.rows()), 8000, 400);
  EXPECT_NE(scan.mesh.V.rows(), face.mesh.V.rows()) << "its own topology";
  const SurfaceLocator locator(scan.mesh.V, scan.mesh.F);
  double worst = 0;
  std::vector<double> chords;
  for (Eigen::Index i = 0; i < scan.truth_point.rows(); ++i) {
    // The stored face + barycentrics reproduce the point, and the point is on the surface.
    const Eigen::RowVector3d from_bary = scan.truth_barycentric(i, 0) * scan.mesh.V.row(scan.mesh.F(scan.truth_face(i), 0)) +
                                         scan.truth_barycentric(i, 1) * scan.mesh.V.row(scan.mesh.F(scan.truth_face(i), 1)) +
                                         scan.truth_barycentric(i, 2) * scan.mesh.V.row(scan.mesh.F(scan.truth_face(i), 2));
    worst = std::max(worst, (from_bary - scan.truth_point.row(i)).norm());
    worst = std::max(worst, (locator.locate(scan.truth_point.row(i).transpose()).point.transpose() - scan.truth_point.row(i)).norm());
    chords.push_back((scan.truth_point.row(i) - (face.mesh.V.row(i) + scan.identity.displacement.row(i))).norm());
  }
  EXPECT_LT(worst, 1e-3) << "mm";
  // The scan approximates the identity surface: most template vertices lie within a small chord of it; the border,
  // which remeshing may pull in by part of an edge, is the worst.
  std::sort(chords.begin(), chords.end());
  EXPECT_LT(chords[chords.size() / 2], 0.05);
  EXPECT_LT(chords[chords.size() * 99 / 100], 0.5);
  EXPECT_LT(chords.back(), 3.0);
  for (int k = 0; k < 68; ++k) {
    EXPECT_EQ(scan.landmarks.points.row(k), scan.truth_point.row(face.landmark_vertices[size_t(k)]));
  }
}

TEST(SynthScan, WrittenScanReadsBackAndIsDeterministic) {
  const TemplateFace& face = test_template();
  SynthOptions opt;
  opt.scan_vertices = 3000;
  opt.maps.resolution = 128;
  opt.truth_resolution = 64;
  const std::string a = testing::temp_dir(), b = testing::temp_dir();
  write_scan(a, face, synthesize_scan(face, 2, opt), opt);
  write_scan(b, face, synthesize_scan(face, 2, opt), opt);
  for (const char* f : {"/subject_0002/mesh.obj", "/subject_0002/landmarks.json", "/subject_0002/diffuse.png",
                        "/subject_0002/normal.png", "/subject_0002/roughness.png", "/subject_0002/specular.png",
                        "/subject_0002/truth/correspondence.safetensors", "/subject_0002/truth/identity.json",
                        "/subject_0002/truth/maps/diffuse.png"}) {
    EXPECT_EQ(read_file(a + f), read_file(b + f)) << f << " differs between two runs with one seed";
  }
  const Mesh mesh = read_mesh(a + "/subject_0002/mesh.obj");
  EXPECT_TRUE(mesh.has_uv());
  const SafeTensors truth = SafeTensors::open(a + "/subject_0002/truth/correspondence.safetensors");
  EXPECT_EQ(truth.tensor("template_to_scan_face").to_vector<int32_t>().size(), size_t(face.mesh.V.rows()));
  const auto faces = truth.tensor("template_to_scan_face").to_vector<int32_t>();
  EXPECT_LT(*std::max_element(faces.begin(), faces.end()), mesh.F.rows());
  EXPECT_EQ(read_landmarks(a + "/subject_0002/landmarks.json").points.rows(), 68);
}

TEST(SynthScan, BadOptionsAreInvalidInput) {
  SynthOptions opt;
  opt.count = 0;
  EXPECT_THROW(opt.check(), InvalidInput);
  opt = SynthOptions();
  opt.identity.symmetry = 2;
  EXPECT_THROW(opt.check(), InvalidInput);
}

}  // namespace
}  // namespace bareskin

#include "scan/blendshapes.h"

namespace bareskin {
namespace {

TEST(Blendshapes, ArkitStyleSetThatIsLocalSmoothAndMirrored) {
  const TemplateFace& face = test_template();
  const std::vector<Blendshape> shapes = make_blendshapes(face);
  ASSERT_GE(shapes.size(), 50u);
  std::map<std::string, const Blendshape*> by_name;
  for (const Blendshape& b : shapes) by_name[b.name] = &b;
  EXPECT_EQ(by_name.size(), shapes.size()) << "names are unique";
  for (const char* name : {"jawOpen", "mouthSmile_L", "mouthSmile_R", "eyeBlink_L", "browInnerUp", "mouthPucker"}) {
    ASSERT_TRUE(by_name.count(name)) << name;
  }
  const Eigen::MatrixX3d before = face_normals(face.mesh.V, face.mesh.F);
  const auto vertex = [&](int landmark) { return face.landmark_vertices[size_t(landmark)]; };
  for (const Blendshape& b : shapes) {
    SCOPED_TRACE(b.name);
    const double peak = b.delta.rowwise().norm().maxCoeff();
    EXPECT_GE(peak, 0.5);
    EXPECT_LT(peak, 25.0) << "a wide-open jaw moves the chin about 2 cm; nothing moves more";
    // Full activation folds no triangle.
    const Eigen::MatrixX3d after = face_normals(face.mesh.V + b.delta, face.mesh.F);
    int folded = 0;
    for (Eigen::Index f = 0; f < before.rows(); ++f) folded += before.row(f).dot(after.row(f)) < 0;
    EXPECT_EQ(folded, 0);
  }
  // Local: a left blink closes the left eye (upper lid 43/44 moves down) and leaves the right eye (37/38) still.
  const Blendshape& blink = *by_name["eyeBlink_L"];
  EXPECT_LT(blink.delta(vertex(44), 1), -1.0);
  EXPECT_LT(blink.delta.row(vertex(37)).norm(), 0.05 * blink.delta.row(vertex(44)).norm());
  // Mirrored: the right smile moves the right corner (48) as the left smile moves the left corner (54), x flipped.
  const Eigen::RowVector3d left = by_name["mouthSmile_L"]->delta.row(vertex(54));
  const Eigen::RowVector3d right = by_name["mouthSmile_R"]->delta.row(vertex(48));
  EXPECT_NEAR(right.x(), -left.x(), 0.2 * std::abs(left.x()) + 0.1);
  EXPECT_NEAR(right.y(), left.y(), 0.2 * std::abs(left.y()) + 0.1);
  // The jaw opens downward at the chin and leaves the forehead still.
  const Blendshape& jaw = *by_name["jawOpen"];
  EXPECT_LT(jaw.delta(vertex(8), 1), -3.0);
  EXPECT_LT(jaw.delta.row(vertex(19)).norm(), 1e-6);
}

TEST(Blendshapes, WrittenSetReadsBackWithNames) {
  const TemplateFace& face = test_template();
  const std::string dir = testing::temp_dir() + "/blendshapes";
  const std::vector<Blendshape> shapes = make_blendshapes(face);
  write_blendshapes(dir, shapes);
  const SafeTensors st = SafeTensors::open(dir + "/blendshapes.safetensors");
  const TensorView& deltas = st.tensor("deltas", DType::F32, {int64_t(shapes.size()), face.mesh.V.rows(), 3});
  EXPECT_NEAR(deltas.as_double((5 * face.mesh.V.rows() + 7) * 3 + 1), shapes[5].delta(7, 1), 1e-5);
  EXPECT_NE(st.metadata().at("names").find("\"jawOpen\""), std::string::npos);
}

}  // namespace
}  // namespace bareskin

namespace bareskin {
namespace {

TEST(SynthScan, PoseJitterIsTheStoredSimilarityAndNoiseKeepsTruthOnTheSurface) {
  const TemplateFace& face = test_template();
  SynthOptions plain;
  plain.scan_vertices = 4000;
  SynthOptions jittered = plain;
  jittered.scale_jitter = 0.1;
  jittered.rotation_jitter_deg = 20;
  jittered.translation_jitter_mm = 50;
  const SyntheticScan a = synthesize_scan(face, 1, plain), b = synthesize_scan(face, 1, jittered);
  EXPECT_EQ(a.identity.displacement, b.identity.displacement) << "knobs leave the identity unchanged";
  EXPECT_FALSE(b.rotation.isIdentity());
  // Independent oracle: Umeyama's least-squares similarity between the two truths is the stored one.
  const Eigen::Matrix4d T = Eigen::umeyama(a.truth_point.transpose(), b.truth_point.transpose(), true);
  const double scale = T.topLeftCorner<3, 3>().determinant() > 0 ? std::cbrt(T.topLeftCorner<3, 3>().determinant()) : 0;
  EXPECT_NEAR(scale, b.scale, 1e-6);
  EXPECT_LT((T.topLeftCorner<3, 3>() / scale - b.rotation).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((T.topRightCorner<3, 1>() - b.translation).cwiseAbs().maxCoeff(), 1e-4);

  SynthOptions noisy = plain;
  noisy.noise_mm = 0.3;
  const SyntheticScan c = synthesize_scan(face, 1, noisy);
  const double rms = std::sqrt((c.mesh.V - a.mesh.V).rowwise().squaredNorm().mean());
  EXPECT_NEAR(rms, 0.3, 0.03) << "vertex noise has the requested sigma";
  const SurfaceLocator locator(c.mesh.V, c.mesh.F);
  for (Eigen::Index i = 0; i < c.truth_point.rows(); i += 13) {
    EXPECT_LT((locator.locate(c.truth_point.row(i).transpose()).point.transpose() - c.truth_point.row(i)).norm(), 1e-3);
  }
  EXPECT_EQ(c.landmarks.points.row(30), c.truth_point.row(face.landmark_vertices[30]));
  noisy.noise_mm = -1;
  EXPECT_THROW(noisy.check(), InvalidInput);
}

}  // namespace
}  // namespace bareskin
