// The synthetic skin and its maps: tone spread, regions where the face has them, the scan's own atlas, and the
// truth chain (a scan texel holds the skin at the template point it corresponds to; the same point baked in the
// template UV agrees, normals included once both are taken out of their own tangent frames).
#include <gtest/gtest.h>

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <functional>
#include <random>
#include <set>

#include "core/image_io.h"
#include "core/mesh_io.h"
#include "scan/test_template.h"
#include "scan/synth.h"

namespace bareskin {
namespace {

using testing::test_template;

int nearest_vertex(const TemplateFace& face, const Eigen::Vector3d& p) {
  Eigen::Index i;
  (face.mesh.V.rowwise() - p.transpose()).rowwise().squaredNorm().minCoeff(&i);
  return int(i);
}

float luminance(const Eigen::Vector3f& c) { return 0.2126f * c.x() + 0.7152f * c.y() + 0.0722f * c.z(); }

TEST(SkinModel, ToneSpansLightToDarkAndRegionsAreWhereTheFaceHasThem) {
  const TemplateFace& face = test_template();
  Eigen::MatrixX2d uv;
  ASSERT_TRUE(per_vertex_uv(face.mesh, uv));
  const auto landmark = [&](int k) { return Eigen::Vector3d(face.mesh.V.row(face.landmark_vertices[size_t(k)])); };
  const auto at = [&](const SkinModel& m, int v) {
    return m.sample(face.mesh.V.row(v).cast<float>(), uv.row(v).cast<float>(), 0.1f).material;
  };
  const int cheek = nearest_vertex(face, (landmark(2) + landmark(31) + landmark(41)) / 3);
  const int lip = nearest_vertex(face, (landmark(51) + landmark(62)) / 2);
  const int brow = nearest_vertex(face, landmark(19) + Eigen::Vector3d(0, -1.5, 0));
  const int forehead = nearest_vertex(face, landmark(19) + Eigen::Vector3d(0, 18, 0));
  const int bridge = face.landmark_vertices[28];

  std::vector<double> melanin, lum;
  for (int s = 0; s < 40; ++s) {
    const SkinModel model(face, sample_appearance(subject_seed(11, s)));
    melanin.push_back(model.appearance().melanin);
    lum.push_back(luminance(at(model, cheek).diffuse));
    // Regions: lips redder and glossier than the cheek, brows darker than the forehead, the T-zone shinier.
    const SkinMaterial c = at(model, cheek), l = at(model, lip), b = at(model, brow), f = at(model, forehead);
    EXPECT_GT(model.lips(uv.row(lip).cast<float>()), 0.9f);
    EXPECT_GT(l.diffuse.x() / l.diffuse.y(), c.diffuse.x() / c.diffuse.y() + 0.1f) << "subject " << s;
    EXPECT_LT(l.roughness, c.roughness);
    EXPECT_GT(model.brows(face.mesh.V.row(brow).cast<float>()), 0.8f);
    EXPECT_LT(luminance(b.diffuse), luminance(f.diffuse));
    EXPECT_GT(model.t_zone(face.mesh.V.row(bridge).cast<float>()), 0.9f);
    EXPECT_GT(at(model, bridge).specular, c.specular);
  }
  const double lightest = *std::max_element(lum.begin(), lum.end()), darkest = *std::min_element(lum.begin(), lum.end());
  EXPECT_GT(lightest, 0.35) << "light skin";
  EXPECT_LT(darkest, 0.08) << "dark skin";
  // Tone follows melanin (rank correlation).
  std::vector<size_t> by_melanin(melanin.size());
  std::iota(by_melanin.begin(), by_melanin.end(), 0);
  std::sort(by_melanin.begin(), by_melanin.end(), [&](size_t a, size_t b) { return melanin[a] < melanin[b]; });
  int inversions = 0, pairs = 0;
  for (size_t i = 0; i < by_melanin.size(); ++i)
    for (size_t j = i + 1; j < by_melanin.size(); ++j, ++pairs) inversions += lum[by_melanin[i]] < lum[by_melanin[j]];
  EXPECT_LT(double(inversions) / pairs, 0.05);
}

// Skin micro-detail (Appearance::detail, for synthetic captures): on the cheek it adds high-frequency albedo
// variation at a 0.1 mm texel (what SIFT needs) while the tone stays put; it is low-passed away at a 2 mm texel, and
// lips and brows are left as they were.
TEST(SkinModel, DetailAddsFineAlbedoVariationKeepsTheToneAndSparesLipsAndBrows) {
  const TemplateFace& face = test_template();
  Eigen::MatrixX2d uv;
  ASSERT_TRUE(per_vertex_uv(face.mesh, uv));
  const auto landmark = [&](int k) { return Eigen::Vector3d(face.mesh.V.row(face.landmark_vertices[size_t(k)])); };
  const int cheek = nearest_vertex(face, (landmark(2) + landmark(31) + landmark(41)) / 3);
  const int lip = nearest_vertex(face, (landmark(51) + landmark(62)) / 2);
  const int brow = nearest_vertex(face, landmark(19) + Eigen::Vector3d(0, -1.5, 0));
  Appearance plain = sample_appearance(subject_seed(11, 3));
  plain.freckles = 0;
  Appearance detailed = plain;
  detailed.detail = 1;
  const SkinModel a(face, plain), b(face, detailed);
  // A 40 x 40 mm patch around the cheek vertex at 0.1 mm steps (every 40th step sampled), then its neighbour steps.
  const Eigen::Vector3f c = face.mesh.V.row(cheek).cast<float>();
  const Eigen::Vector2f c_uv = uv.row(cheek).cast<float>();
  const auto fine_variation = [&](const SkinModel& m, float footprint, double* mean) {
    double sum = 0, diff2 = 0;
    int n = 0;
    for (int i = -20; i < 20; ++i)
      for (int j = -20; j < 20; ++j) {
        const Eigen::Vector3f p = c + Eigen::Vector3f(float(i), float(j), 0);
        const float l0 = luminance(m.sample(p, c_uv, footprint).material.diffuse);
        const float l1 = luminance(m.sample(p + Eigen::Vector3f(footprint, 0, 0), c_uv, footprint).material.diffuse);
        sum += l0, diff2 += double(l1 - l0) * (l1 - l0), ++n;
      }
    *mean = sum / n;
    return std::sqrt(diff2 / n);
  };
  double mean_a, mean_b;
  const double fine_a = fine_variation(a, 0.1f, &mean_a), fine_b = fine_variation(b, 0.1f, &mean_b);
  EXPECT_GT(fine_b, 2 * fine_a) << "neighbouring 0.1 mm texels differ more with detail";
  EXPECT_NEAR(mean_b / mean_a, 1.0, 0.1) << "the tone stays";
  double coarse_mean;
  const double coarse_a = fine_variation(a, 2.0f, &coarse_mean), coarse_b = fine_variation(b, 2.0f, &coarse_mean);
  EXPECT_LT(coarse_b - coarse_a, 0.25 * (fine_b - fine_a)) << "low-passed at a 2 mm texel";
  for (const int v : {lip, brow}) {
    const SkinMaterial m0 = a.sample(face.mesh.V.row(v).cast<float>(), uv.row(v).cast<float>(), 0.1f).material;
    const SkinMaterial m1 = b.sample(face.mesh.V.row(v).cast<float>(), uv.row(v).cast<float>(), 0.1f).material;
    EXPECT_LT((m1.diffuse - m0.diffuse).norm(), 0.02f * m0.diffuse.norm()) << "vertex " << v;
  }
  EXPECT_EQ(detailed.to_map().at("detail"), 1);
  EXPECT_EQ(plain.to_map().count("detail"), 0u) << "scans without detail keep their identity files";
}

// Returns the face of `mesh` whose atlas triangle contains uv (or -1) and the barycentrics there.
int find_uv_face(const Mesh& mesh, const Eigen::Vector2d& uv, Eigen::Vector3f& bary) {
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector2d a = mesh.UV.row(mesh.FUV(f, 0)), b = mesh.UV.row(mesh.FUV(f, 1)), c = mesh.UV.row(mesh.FUV(f, 2));
    const auto cross = [](const Eigen::Vector2d& x, const Eigen::Vector2d& y) { return x.x() * y.y() - x.y() * y.x(); };
    const double area = cross(b - a, c - a);
    if (std::abs(area) < 1e-14) continue;
    const double s = cross(uv - a, c - a) / area, t = cross(b - a, uv - a) / area;
    if (s >= 0 && t >= 0 && s + t <= 1) {
      bary = Eigen::Vector3f(float(1 - s - t), float(s), float(t));
      return int(f);
    }
  }
  return -1;
}

TEST(SkinBake, MapsHoldTheSkinAtTheTemplatePointAndAgreeWithTheTemplateUvTruth) {
  const TemplateFace& face = test_template();
  SynthOptions opt;
  opt.scan_vertices = 6000;
  const SyntheticScan scan = synthesize_scan(face, 3, opt);
  const SkinModel model(face, scan.appearance);
  const SkinBaker baker(scan.surface, model);
  const SkinSurface truth_surface = template_skin_surface(face, scan.identity.displacement);
  const SkinBaker truth(truth_surface, model);

  BakeOptions bake;
  bake.resolution = 256;
  const std::string dir = testing::temp_dir();
  baker.bake(dir, bake);
  const Image diffuse = read_image(dir + "/diffuse.png"), normal = read_image(dir + "/normal.png", ColorSpace::Data);
  const Image roughness = read_image(dir + "/roughness.png", ColorSpace::Data);
  ASSERT_EQ(diffuse.width, 256);
  EXPECT_EQ(diffuse.color_space, ColorSpace::sRGB);

  std::mt19937 rng(5);
  std::uniform_int_distribution<int> texel(0, 255);
  int checked = 0;
  std::vector<double> colour_error, angle_error;
  while (checked < 150) {
    const int x = texel(rng), y = texel(rng);
    const Eigen::Vector2d uv((x + 0.5) / 256, 1 - (y + 0.5) / 256);
    Eigen::Vector3f b;
    const int f = find_uv_face(scan.mesh, uv, b);
    if (f < 0) continue;
    ++checked;
    // 1. The texel holds what the bake computes there (orientation, rows, encoding, 16-bit quantisation).
    const SkinTexel expected = baker.evaluate(f, b, baker.mm_per_uv(f) / 256);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(diffuse.at(x, y, k), linear_to_srgb(expected.material.diffuse[k]), 3e-5);
      EXPECT_NEAR(normal.at(x, y, k), 0.5f * (expected.normal[k] + 1), 3e-5);
    }
    EXPECT_NEAR(roughness.at(x, y), expected.material.roughness, 3e-5);
    // 2. The same surface point on the truth surface (template UV): same colour, same world normal.
    Eigen::Vector2d tuv = Eigen::Vector2d::Zero();
    for (int k = 0; k < 3; ++k) tuv += double(b[k]) * scan.surface.template_uv.row(scan.mesh.F(f, k)).transpose();
    Eigen::Vector3f tb;
    const int tf = find_uv_face(truth_surface.mesh, tuv, tb);
    if (tf < 0) continue;  // the template UV has a sliver fold or the point is on its border
    const SkinTexel other = truth.evaluate(tf, tb, baker.mm_per_uv(f) / 256);
    colour_error.push_back((other.material.diffuse - expected.material.diffuse).cwiseAbs().maxCoeff());
    const Eigen::Vector3f n_scan = baker.frame(f, b) * expected.normal, n_truth = truth.frame(tf, tb) * other.normal;
    angle_error.push_back(std::acos(std::clamp(double(n_scan.dot(n_truth)), -1.0, 1.0)) * 180 / M_PI);
  }
  ASSERT_GT(colour_error.size(), 100u);
  std::sort(colour_error.begin(), colour_error.end());
  std::sort(angle_error.begin(), angle_error.end());
  EXPECT_LT(colour_error[colour_error.size() / 2], 2e-3);
  EXPECT_LT(colour_error[colour_error.size() * 95 / 100], 1e-2);
  EXPECT_LT(angle_error[angle_error.size() / 2], 1.0) << "degrees";
  EXPECT_LT(angle_error[angle_error.size() * 95 / 100], 3.0) << "degrees";
}

TEST(SynthScan, AtlasIsItsOwnTwoChartsInjectiveAlmostEverywhere) {
  const TemplateFace& face = test_template();
  SynthOptions opt;
  opt.scan_vertices = 6000;
  const SyntheticScan scan = synthesize_scan(face, 4, opt);
  const Mesh& m = scan.mesh;
  ASSERT_TRUE(m.has_uv());
  EXPECT_GT(m.UV.rows(), m.V.rows()) << "the midline cut is a seam";
  EXPECT_GE(m.UV.minCoeff(), 0.0);
  EXPECT_LE(m.UV.maxCoeff(), 1.0);
  int positive = 0, negative = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector2d a = m.UV.row(m.FUV(f, 0)), b = m.UV.row(m.FUV(f, 1)), c = m.UV.row(m.FUV(f, 2));
    const double area = (b - a).x() * (c - a).y() - (c - a).x() * (b - a).y();
    (area > 0 ? positive : negative)++;
  }
  EXPECT_LT(double(std::min(positive, negative)) / m.F.rows(), 2e-3) << "flipped atlas triangles";
  // Not an affine image of the template UV: the least-squares affine fit leaves a clear residual.
  Eigen::MatrixXd A(m.F.rows(), 3), B(m.F.rows(), 2);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    A.row(f) << scan.surface.template_uv.row(m.F(f, 0)), 1;
    B.row(f) = m.UV.row(m.FUV(f, 0));
  }
  const Eigen::MatrixXd fit = A.colPivHouseholderQr().solve(B);
  EXPECT_GT(std::sqrt((A * fit - B).rowwise().squaredNorm().mean()), 0.02);
}

int boundary_loops(const Mesh& mesh) {
  const Eigen::MatrixX2i edges = boundary_edges(mesh.F);
  std::vector<int> parent(size_t(mesh.V.rows()));
  std::iota(parent.begin(), parent.end(), 0);
  const std::function<int(int)> find = [&](int v) { return parent[size_t(v)] == v ? v : parent[size_t(v)] = find(parent[size_t(v)]); };
  for (Eigen::Index e = 0; e < edges.rows(); ++e) parent[size_t(find(edges(e, 0)))] = find(edges(e, 1));
  std::set<int> roots;
  for (Eigen::Index e = 0; e < edges.rows(); ++e) roots.insert(find(edges(e, 0)));
  return int(roots.size());
}

TEST(SynthScan, HolesOpenBothNostrilsAndKeepTheMeshManifold) {
  const TemplateFace& face = test_template();
  SynthOptions opt;
  opt.scan_vertices = 30000;
  opt.maps.resolution = 0;
  const SyntheticScan closed = synthesize_scan(face, 5, opt);
  opt.holes = true;
  const SyntheticScan open = synthesize_scan(face, 5, opt);
  EXPECT_EQ(boundary_loops(open.mesh), boundary_loops(closed.mesh) + 2);
  const int in_hole = int((open.truth_face.array() < 0).count());
  EXPECT_GT(in_hole, 0);
  EXPECT_LT(in_hole, face.mesh.V.rows() / 100);
  const std::string path = testing::temp_dir() + "/open.obj";
  write_mesh(path, open.mesh);
  EXPECT_EQ(read_mesh(path).F.rows(), open.mesh.F.rows()) << "no face dropped as non-manifold";
}

}  // namespace
}  // namespace bareskin
