#include "scan/identity.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.h"
#include "core/mesh.h"
#include "core/parallel.h"

namespace bareskin {
namespace {

// A semantic control: a smooth bump (Gaussian falloff of the distance to anchor landmarks) moving vertices along a
// direction. `mirror_x` makes the left/right halves move in opposite x (widening); otherwise the direction is shared.
struct Feature {
  const char* name;
  std::vector<int> anchors;  // iBUG-68 indices
  double radius_mm;
  Eigen::Vector3d direction;
  double strength_mm;  // one standard deviation
  bool mirror_x;
};

const std::vector<Feature>& features() {
  static const std::vector<Feature> table = {
      {"nose_length", {30}, 12.0, {0, 0, 1}, 2.5, false},
      {"nose_width", {31, 35}, 7.0, {1, 0, 0}, 1.5, true},
      {"nose_bridge", {27, 28}, 10.0, {0, 0, 1}, 1.5, false},
      {"jaw_width", {3, 4, 5, 11, 12, 13}, 18.0, {1, 0, 0}, 3.5, true},
      {"chin_length", {7, 8, 9}, 14.0, {0, -1, 0.3}, 3.0, false},
      {"cheekbones", {1, 15}, 16.0, {0.6, 0, 0.8}, 2.5, true},
      {"eye_spacing", {36, 39, 42, 45}, 9.0, {1, 0, 0}, 1.5, true},
      {"lip_thickness", {50, 51, 52, 56, 57, 58}, 7.0, {0, 0, 1}, 1.5, false},
      {"brow_ridge", {19, 24}, 14.0, {0, 0, 1}, 2.0, false},
  };
  return table;
}

// Vertex normals diffused over about `radius_mm` (one-ring averaging, as many rounds as the mesh density needs).
Eigen::MatrixX3d smooth_normals(const Mesh& mesh, double radius_mm) {
  Eigen::MatrixX3d N = vertex_normals(mesh.V, mesh.F);
  double edge = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) edge += (mesh.V.row(mesh.F(f, 0)) - mesh.V.row(mesh.F(f, 1))).norm();
  edge /= double(std::max<Eigen::Index>(1, mesh.F.rows()));
  const int rounds = std::clamp(int(std::pow(radius_mm / std::max(edge, 1e-9), 2)), 1, 400);
  for (int r = 0; r < rounds; ++r) {
    Eigen::MatrixX3d sum = N;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) sum.row(mesh.F(f, k)) += N.row(mesh.F(f, (k + 1) % 3)) + N.row(mesh.F(f, (k + 2) % 3));
    N = sum.rowwise().normalized();
  }
  return N;
}

// x -> -x
Eigen::Vector3d mirror(const Eigen::Vector3d& v) { return {-v.x(), v.y(), v.z()}; }

}  // namespace

void IdentityOptions::check() const {
  if (gp_lengths.size() != gp_sigmas.size()) throw InvalidInput("", "gp_lengths and gp_sigmas differ in length", "");
  for (size_t i = 0; i < gp_lengths.size(); ++i) {
    if (!(gp_lengths[i] > 0) || !(gp_sigmas[i] >= 0)) throw InvalidInput("", "GP lengths must be > 0, sigmas >= 0", "");
  }
  if (fourier_features < 1 || fourier_features > 100000) throw InvalidInput("", "fourier_features must lie in [1, 100000]", "");
  if (!(symmetry >= 0 && symmetry <= 1)) throw InvalidInput("", "symmetry must lie in [0, 1]", "");
  if (!(feature_scale >= 0)) throw InvalidInput("", "feature_scale must be >= 0", "");
  if (!(tangential >= 0 && tangential <= 1)) throw InvalidInput("", "tangential must lie in [0, 1]", "");
}

std::vector<std::string> identity_feature_names() {
  std::vector<std::string> names;
  for (const Feature& f : features()) names.push_back(f.name);
  return names;
}

Identity sample_identity(const TemplateFace& face, uint64_t seed, const IdentityOptions& options) {
  options.check();
  if (face.landmark_vertices.size() != 68) {
    throw InvalidInput("template", "needs the 68 iBUG landmark vertices for feature controls", "give a landmark file");
  }
  const Eigen::MatrixX3d& V = face.mesh.V;
  Identity id;
  id.seed = seed;
  id.displacement = Eigen::MatrixX3d::Zero(V.rows(), 3);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> phase(0.0, 2 * M_PI);

  // Random Fourier features: for k(x,y) = s^2 exp(-|x-y|^2 / (2 l^2)), f(x) = s sqrt(2/M) sum_m a_m cos(w_m.x + b_m)
  // with w_m ~ N(0, I/l^2), b_m ~ U(0, 2pi), a_m ~ N(0, I_3) is a sample whose covariance tends to k as M grows.
  const Eigen::RowVector3d centre = V.colwise().mean();
  for (size_t s = 0; s < options.gp_lengths.size(); ++s) {
    const int M = options.fourier_features;
    Eigen::MatrixX3d W(M, 3), A_sym(M, 3), A_asym(M, 3);
    Eigen::VectorXd B(M);
    for (int m = 0; m < M; ++m) {
      for (int k = 0; k < 3; ++k) W(m, k) = normal(rng) / options.gp_lengths[s];
      for (int k = 0; k < 3; ++k) A_sym(m, k) = normal(rng);
      for (int k = 0; k < 3; ++k) A_asym(m, k) = normal(rng);
      B(m) = phase(rng);
    }
    const double amplitude = options.gp_sigmas[s] * std::sqrt(2.0 / M);
    const double ws = std::sqrt(options.symmetry), wa = std::sqrt(1 - options.symmetry);  // keeps the variance
    parallel_for(0, V.rows(), [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) {
        const Eigen::Vector3d x = (V.row(i) - centre).transpose(), xm = mirror(x);
        Eigen::Vector3d sym = Eigen::Vector3d::Zero(), asym = Eigen::Vector3d::Zero();
        for (int m = 0; m < M; ++m) {
          const double c = std::cos(W.row(m).dot(x) + B(m)), cm = std::cos(W.row(m).dot(xm) + B(m));
          // f_sym(x) = (f(x) + mirror(f(mirror(x)))) / sqrt(2): an x-symmetric field with the same variance.
          sym += (c * A_sym.row(m).transpose() + cm * mirror(A_sym.row(m).transpose())) / std::sqrt(2.0);
          asym += c * A_asym.row(m).transpose();
        }
        id.displacement.row(i) += amplitude * (ws * sym + wa * asym).transpose();
      }
    }, 256);
  }

  for (const Feature& f : features()) {
    const double strength = normal(rng);
    id.features[f.name] = strength;
    const double mm = strength * f.strength_mm * options.feature_scale;
    std::vector<Eigen::Vector3d> anchors;
    for (int a : f.anchors) anchors.push_back(V.row(face.landmark_vertices[size_t(a)]).transpose());
    for (Eigen::Index i = 0; i < V.rows(); ++i) {
      const Eigen::Vector3d x = V.row(i).transpose();
      double weight = 0;
      for (const auto& a : anchors) weight = std::max(weight, std::exp(-(x - a).squaredNorm() / (2 * f.radius_mm * f.radius_mm)));
      Eigen::Vector3d dir = f.direction.normalized();
      if (f.mirror_x) dir.x() *= std::tanh(x.x() / 5.0);  // left and right move apart, smoothly across the midline
      id.displacement.row(i) += (mm * weight * dir).transpose();
    }
  }
  // Faces differ mostly across their surface, not along it: keep `tangential` of the tangential part, with
  // the normal taken from a smoothed normal field (about 10 mm), so that creases (nostrils, lips) do not fold.
  if (options.tangential < 1) {
    const Eigen::MatrixX3d N = smooth_normals(face.mesh, 10.0);
    for (Eigen::Index i = 0; i < V.rows(); ++i) {
      const Eigen::RowVector3d d = id.displacement.row(i), n = N.row(i);
      const Eigen::RowVector3d along = d.dot(n) * n;
      id.displacement.row(i) = along + options.tangential * (d - along);
    }
  }

  return id;
}

}  // namespace bareskin
