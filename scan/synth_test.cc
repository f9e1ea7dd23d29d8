#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <numeric>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/safetensors.h"
#include "core/test_util.h"
#include "morphable/surface.h"
#include "scan/synth.h"

namespace bareskin {
namespace {

// The template made by the ctest fixture (6k vertices) keeps these tests fast.
const TemplateFace& test_template() {
  static const TemplateFace face = read_template(std::string(BARESKIN_TEMPLATE_DIR) + "/face.obj",
                                                 std::string(BARESKIN_TEMPLATE_DIR) + "/landmarks.json");
  return face;
}

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
  const std::string a = testing::temp_dir(), b = testing::temp_dir();
  write_scan(a, synthesize_scan(face, 2, opt), opt);
  write_scan(b, synthesize_scan(face, 2, opt), opt);
  for (const char* f : {"/subject_0002/mesh.ply", "/subject_0002/landmarks.json",
                        "/subject_0002/truth/correspondence.safetensors", "/subject_0002/truth/identity.json"}) {
    EXPECT_EQ(read_file(a + f), read_file(b + f)) << f << " differs between two runs with one seed";
  }
  const Mesh mesh = read_mesh(a + "/subject_0002/mesh.ply");
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
