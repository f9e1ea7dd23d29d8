#include "scan/model_prior.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

#include "core/error.h"
#include "core/parallel.h"
#include "core/similarity.h"
#include "core/stats.h"

namespace bareskin {
namespace {

Eigen::Matrix3d cross_matrix(const Eigen::Vector3d& p) {
  Eigen::Matrix3d m;
  m << 0, -p.z(), p.y(), p.z(), 0, -p.x(), -p.y(), p.x(), 0;
  return m;
}

// The identity basis with its standard deviations folded in: 3V x K, row 3i + c for vertex i, axis c.
Eigen::MatrixXd scaled_basis(const MorphableModel& model, int k) {
  Eigen::MatrixXd B = model.shape_basis.topRows(k).transpose().cast<double>();
  for (int j = 0; j < k; ++j) B.col(j) *= double(model.shape_stddev(j));
  return B;
}

// The normal equations of one round, in the unknowns [α (K), ω (3), τ (3), σ (1)]: the shape's coefficients and a
// small similarity about the centroid c̄ of the current shape X0 (rotation ω, translation τ, scale 1 + σ), linearised:
// X ≈ sR (S̄ + B α) + t + ω × (X0 − c̄) + σ (X0 − c̄) + τ.
struct NormalEquations {
  explicit NormalEquations(int n) : A(Eigen::MatrixXd::Zero(n, n)), b(Eigen::VectorXd::Zero(n)) {}
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  void add(const Eigen::MatrixXd& J, const Eigen::VectorXd& r, double w) {
    A.noalias() += w * J.transpose() * J;
    b.noalias() += w * J.transpose() * r;
  }
};

// One Poisson-disk pass at spacing r: vertices in index order, kept when no kept one lies within r (a hash grid of
// cell r, so only the 27 neighbouring cells are looked at).
std::vector<int> poisson_disk(const Eigen::MatrixX3d& V, double r) {
  const auto cell = [&](const Eigen::RowVector3d& p) {
    return Eigen::Vector3i(int(std::floor(p.x() / r)), int(std::floor(p.y() / r)), int(std::floor(p.z() / r)));
  };
  const auto key = [](const Eigen::Vector3i& c) {
    return (uint64_t(uint32_t(c.x()) & 0x1fffff) << 42) | (uint64_t(uint32_t(c.y()) & 0x1fffff) << 21) |
           uint64_t(uint32_t(c.z()) & 0x1fffff);
  };
  std::unordered_map<uint64_t, std::vector<int>> grid;
  std::vector<int> kept;
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const Eigen::Vector3i c = cell(V.row(i));
    bool free = true;
    for (int dx = -1; dx <= 1 && free; ++dx)
      for (int dy = -1; dy <= 1 && free; ++dy)
        for (int dz = -1; dz <= 1 && free; ++dz) {
          const auto it = grid.find(key(c + Eigen::Vector3i(dx, dy, dz)));
          if (it == grid.end()) continue;
          for (const int j : it->second)
            if ((V.row(j) - V.row(i)).squaredNorm() < r * r) {
              free = false;
              break;
            }
        }
    if (!free) continue;
    grid[key(c)].push_back(int(i));
    kept.push_back(int(i));
  }
  return kept;
}

}  // namespace

std::vector<int> spread_vertices(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int count) {
  std::vector<int> all(size_t(V.rows()));
  for (size_t i = 0; i < all.size(); ++i) all[i] = int(i);
  if (count <= 0 || count >= V.rows()) return all;
  // An even (hexagonal) sampling at spacing r has 2 / (sqrt(3) r^2) points per unit area; a greedy pass packs less
  // densely, so start a little closer and correct the spacing by the count it gave (twice).
  double r = 0.8 * std::sqrt(2 * surface_area(V, F) / (std::sqrt(3.0) * count));
  std::vector<int> kept = poisson_disk(V, r);
  for (int pass = 0; pass < 2 && std::abs(double(kept.size()) / count - 1) > 0.05; ++pass) {
    r *= std::sqrt(double(kept.size()) / count);
    kept = poisson_disk(V, r);
  }
  return kept;
}

void ModelPriorOptions::check() const {
  if (iterations < 1 || iterations > 100) throw InvalidInput("", "--model-iterations must lie in [1, 100]", "");
  if (components < 0) throw InvalidInput("", "--model-components must be >= 0 (0: all)", "");
  if (!(regularisation > 0)) throw InvalidInput("", "--model-regularisation must be > 0", "");
  if (!(landmark_weight >= 0)) throw InvalidInput("", "--model-landmark-weight must be >= 0", "");
  if (trim_mm.empty()) throw InvalidInput("", "the model fit's trim schedule is empty", "");
  for (const double t : trim_mm)
    if (!(t > 0)) throw InvalidInput("", "the model fit's trims must be > 0 mm", "");
  if (!(nicp_landmark_scale >= 0)) throw InvalidInput("", "--model-nicp-landmark-scale must be >= 0", "");
  if (vertices != 0 && vertices < 200) throw InvalidInput("", "--model-vertices must be 0 (all) or >= 200", "");
}

std::vector<double> landmark_sigma_weights(const std::vector<double>& sigma_mm) {
  if (sigma_mm.empty()) return {};
  std::vector<double> known;
  for (const double s : sigma_mm)
    if (s > 0 && std::isfinite(s)) known.push_back(s);
  std::vector<double> w(sigma_mm.size(), 1.0);
  if (known.empty()) return w;
  const double typical = quantile(known, 0.5);
  for (size_t k = 0; k < sigma_mm.size(); ++k)
    if (sigma_mm[k] > 0 && std::isfinite(sigma_mm[k])) w[k] = std::min(1.0, std::pow(typical / sigma_mm[k], 2));
  return w;
}

void check_model_template(const MorphableModel& model, const Mesh& template_mesh, const std::vector<int>& landmark_vertices,
                          const std::string& model_path) {
  const bool same = model.topology.V.rows() == template_mesh.V.rows() &&
                    model.topology.F.rows() == template_mesh.F.rows() && model.topology.F == template_mesh.F &&
                    model.landmark_vertices == landmark_vertices;
  if (same) return;
  throw InvalidInput(model_path,
                     "was built on another template (" + std::to_string(model.topology.V.rows()) + " vertices, " +
                         std::to_string(model.topology.F.rows()) + " triangles; the template has " +
                         std::to_string(template_mesh.V.rows()) + " and " + std::to_string(template_mesh.F.rows()) +
                         ", or other triangles or landmark vertices)",
                     "give the model mm-build made from registrations to this --template");
}

ModelPriorFit fit_model_to_scan(const MorphableModel& model, const Eigen::MatrixX3d& start, const ScanTargetQuery& query,
                                const Eigen::MatrixX3d* landmarks, const std::vector<int>& landmark_ids,
                                const std::vector<double>& landmark_sigma_mm, const ModelPriorOptions& options) {
  options.check();
  const Eigen::MatrixX3d& mean = model.topology.V;
  const Eigen::Index n = mean.rows();
  BS_CHECK(start.rows() == n, "fit_model_to_scan: the start is not in the model's topology");
  const int K = options.components > 0 ? std::min(options.components, int(model.shape_basis.rows()))
                                       : int(model.shape_basis.rows());
  const Eigen::MatrixXd B = scaled_basis(model, K);
  const int unknowns = K + 7;
  const std::vector<double> sigma_weight = landmark_sigma_weights(landmark_sigma_mm);

  ModelPriorFit fit;
  fit.alpha = Eigen::VectorXd::Zero(K);
  fit.similarity = Eigen::umeyama(mean.transpose(), start.transpose(), true);
  const auto shape = [&](const Eigen::VectorXd& alpha) {
    const Eigen::VectorXd flat = B * alpha;
    return Eigen::MatrixX3d(mean + Eigen::Map<const Eigen::Matrix<double, -1, 3, Eigen::RowMajor>>(flat.data(), n, 3));
  };
  // The vertices whose closest points the rounds use: spread over the model's mean surface.
  const std::vector<int> sample = spread_vertices(mean, model.topology.F, options.vertices);
  fit.vertices_used = int(sample.size());
  for (int round = 0; round < options.iterations; ++round) {
    const Eigen::MatrixX3d X0 = transformed(fit.similarity, shape(fit.alpha));
    const double trim = options.trim_mm[std::min(size_t(round), options.trim_mm.size() - 1)];
    const ScanTargets tg = query(X0, sample, trim);
    const Eigen::Matrix3d sR = fit.similarity.topLeftCorner<3, 3>();
    const Eigen::Vector3d t = fit.similarity.topRightCorner<3, 1>();
    const Eigen::RowVector3d centre = X0.colwise().mean();
    // Surface: one point-to-plane row per accepted sample vertex (rows of M, right-hand sides r, weights w), weights
    // normalised to a mean.
    std::vector<Eigen::Index> rows;  // indices into `sample` (and tg)
    for (Eigen::Index j = 0; j < Eigen::Index(sample.size()); ++j)
      if (tg.weight(j) > 0) rows.push_back(j);
    if (rows.size() < 100)
      throw InvalidInput("scan", "the model fit found almost no overlap with the scan", "check the landmarks");
    const Eigen::Index m = Eigen::Index(rows.size());
    Eigen::MatrixXd M(m, unknowns);
    Eigen::VectorXd r(m), w(m);
    double total = 0, squared = 0;
    parallel_for(0, m, [&](int64_t b, int64_t e) {
      for (int64_t j = b; j < e; ++j) {
        const Eigen::Index q = rows[size_t(j)], i = sample[size_t(q)];
        const Eigen::Vector3d nrm = tg.normal.row(q).transpose(), p = (X0.row(i) - centre).transpose();
        M.block(j, 0, 1, K).noalias() = (nrm.transpose() * sR) * B.middleRows(3 * i, 3);
        M.block<1, 3>(j, K) = p.cross(nrm).transpose();
        M.block<1, 3>(j, K + 3) = nrm.transpose();
        M(j, K + 6) = nrm.dot(p);
        r(j) = nrm.dot(tg.point.row(q).transpose() - t - sR * mean.row(i).transpose());
        w(j) = tg.weight(q);
      }
    }, 4096);
    for (Eigen::Index j = 0; j < m; ++j) {
      const Eigen::Index q = rows[size_t(j)];
      const double now = tg.normal.row(q).dot(tg.point.row(q) - X0.row(sample[size_t(q)]));
      squared += w(j) * now * now;
      total += w(j);
    }
    fit.rms_mm.push_back(std::sqrt(squared / total));
    const Eigen::MatrixXd WM = w.asDiagonal() * M;
    NormalEquations system(unknowns);
    system.A.noalias() = WM.transpose() * M / total;
    system.b.noalias() = WM.transpose() * r / total;
    // Landmarks: three rows each, weakly.
    if (landmarks && options.landmark_weight > 0 && !landmark_ids.empty()) {
      NormalEquations lm(unknowns);
      double lm_total = 0;
      Eigen::MatrixXd L(3, unknowns);
      for (const int k : landmark_ids) {
        const int v = model.landmark_vertices[size_t(k)];
        const double w = sigma_weight.empty() ? 1.0 : sigma_weight[size_t(k)];
        const Eigen::Vector3d p = (X0.row(v) - centre).transpose();
        L.block(0, 0, 3, K) = sR * B.middleRows(3 * v, 3);
        L.block<3, 3>(0, K) = -cross_matrix(p);
        L.block<3, 3>(0, K + 3).setIdentity();
        L.block<3, 1>(0, K + 6) = p;
        lm.add(L, landmarks->row(k).transpose() - t - sR * mean.row(v).transpose(), w);
        lm_total += w;
      }
      system.A += options.landmark_weight / lm_total * lm.A;
      system.b += options.landmark_weight / lm_total * lm.b;
    }
    for (int j = 0; j < K; ++j) system.A(j, j) += options.regularisation;
    for (int j = K; j < unknowns; ++j) system.A(j, j) += 1e-9;  // the similarity: no prior, only kept solvable
    const Eigen::VectorXd x = system.A.ldlt().solve(system.b);
    if (!x.allFinite()) throw InternalError("model fit: the normal equations gave a non-finite solution");
    // The new coefficients; the similarity's increment about the centre, composed on the left.
    fit.alpha = x.head(K);
    const Eigen::Vector3d omega = x.segment<3>(K), tau = x.segment<3>(K + 3);
    const double scale = 1 + x(K + 6);
    const Eigen::Matrix3d R = omega.norm() > 0 ? Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix()
                                               : Eigen::Matrix3d::Identity();
    Eigen::Matrix4d D = Eigen::Matrix4d::Identity();
    D.topLeftCorner<3, 3>() = scale * R;
    D.topRightCorner<3, 1>() = centre.transpose() - scale * R * centre.transpose() + tau;
    fit.similarity = D * fit.similarity;
  }
  fit.V = transformed(fit.similarity, shape(fit.alpha));
  if (landmarks && !landmark_ids.empty()) {
    double s = 0;
    for (const int k : landmark_ids) s += (fit.V.row(model.landmark_vertices[size_t(k)]) - landmarks->row(k)).squaredNorm();
    fit.landmark_rms_mm = std::sqrt(s / double(landmark_ids.size()));
  }
  return fit;
}

}  // namespace bareskin
