#include "scan/model_prior.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "core/stats.h"

namespace bareskin {
namespace {

Eigen::MatrixX3d apply(const Eigen::Matrix4d& T, const Eigen::MatrixX3d& V) {
  return ((V * T.topLeftCorner<3, 3>().transpose()).rowwise() + T.topRightCorner<3, 1>().transpose()).eval();
}

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

}  // namespace

void ModelPriorOptions::check() const {
  if (iterations < 1 || iterations > 100) throw InvalidInput("", "--model-iterations must lie in [1, 100]", "");
  if (components < 0) throw InvalidInput("", "--model-components must be >= 0 (0: all)", "");
  if (!(regularisation > 0)) throw InvalidInput("", "--model-regularisation must be > 0", "");
  if (!(landmark_weight >= 0)) throw InvalidInput("", "--model-landmark-weight must be >= 0", "");
  if (trim_mm.empty()) throw InvalidInput("", "the model fit's trim schedule is empty", "");
  for (const double t : trim_mm)
    if (!(t > 0)) throw InvalidInput("", "the model fit's trims must be > 0 mm", "");
  if (!(nicp_landmark_scale >= 0)) throw InvalidInput("", "--model-nicp-landmark-scale must be >= 0", "");
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
  for (int round = 0; round < options.iterations; ++round) {
    const Eigen::MatrixX3d X0 = apply(fit.similarity, shape(fit.alpha));
    const double trim = options.trim_mm[std::min(size_t(round), options.trim_mm.size() - 1)];
    const ScanTargets tg = query(X0, trim);
    const Eigen::Matrix3d sR = fit.similarity.topLeftCorner<3, 3>();
    const Eigen::Vector3d t = fit.similarity.topRightCorner<3, 1>();
    const Eigen::RowVector3d centre = X0.colwise().mean();
    // Surface: one point-to-plane row per accepted vertex (rows of M, right-hand sides r, weights w), weights
    // normalised to a mean.
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < n; ++i)
      if (tg.weight(i) > 0) rows.push_back(i);
    if (rows.size() < 100) throw InvalidInput("scan", "the model fit found almost no overlap with the scan", "check the landmarks");
    const Eigen::Index m = Eigen::Index(rows.size());
    Eigen::MatrixXd M(m, unknowns);
    Eigen::VectorXd r(m), w(m);
    double total = 0, squared = 0;
    parallel_for(0, m, [&](int64_t b, int64_t e) {
      for (int64_t j = b; j < e; ++j) {
        const Eigen::Index i = rows[size_t(j)];
        const Eigen::Vector3d nrm = tg.normal.row(i).transpose(), p = (X0.row(i) - centre).transpose();
        M.block(j, 0, 1, K).noalias() = (nrm.transpose() * sR) * B.middleRows(3 * i, 3);
        M.block<1, 3>(j, K) = p.cross(nrm).transpose();
        M.block<1, 3>(j, K + 3) = nrm.transpose();
        M(j, K + 6) = nrm.dot(p);
        r(j) = nrm.dot(tg.point.row(i).transpose() - t - sR * mean.row(i).transpose());
        w(j) = tg.weight(i);
      }
    }, 4096);
    for (Eigen::Index j = 0; j < m; ++j) {
      const double now = tg.normal.row(rows[size_t(j)]).dot(tg.point.row(rows[size_t(j)]) - X0.row(rows[size_t(j)]));
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
  fit.V = apply(fit.similarity, shape(fit.alpha));
  if (landmarks && !landmark_ids.empty()) {
    double s = 0;
    for (const int k : landmark_ids) s += (fit.V.row(model.landmark_vertices[size_t(k)]) - landmarks->row(k)).squaredNorm();
    fit.landmark_rms_mm = std::sqrt(s / double(landmark_ids.size()));
  }
  return fit;
}

}  // namespace bareskin
