#include "morphable/fit.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <cmath>

#include "core/error.h"

namespace bareskin {

void LandmarkFitOptions::check() const {
  if (shape_components < 0 || expression_components < 0) {
    throw InvalidInput("", "--shape-components and --expression-components must be >= 0", "");
  }
  if (!(regularisation >= 0)) throw InvalidInput("", "--regularisation must be >= 0", "");
  if (iterations < 1 || iterations > 1000) throw InvalidInput("", "--iterations must lie in [1, 1000]", "");
}

Eigen::Matrix3d euler_rotation(const Eigen::Vector3d& a) {
  return (Eigen::AngleAxisd(a.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(a.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a.x(), Eigen::Vector3d::UnitX())).toRotationMatrix();
}

LandmarkFit fit_landmarks(const MorphableModel& model, const Eigen::MatrixX2d& target, const Camera& camera,
                          const LandmarkFitOptions& options) {
  options.check();
  if (model.landmark_vertices.size() != 68 || target.rows() != 68) {
    throw InvalidInput("", "the fit needs 68 model landmarks and 68 image landmarks", "");
  }
  if (!target.allFinite()) throw InvalidInput("", "the image landmarks hold NaN or Inf", "");
  const int Ka = std::min<int>(options.shape_components, int(model.shape_basis.rows()));
  const int Kb = std::min<int>(options.expression_components, int(model.expression_basis.rows()));
  const int K = Ka + Kb;
  // The landmark rows of the mean and of the scaled bases: S_k = mean_k + Σ_j α_j σ_j U_j,k + Σ_j β_j σ'_j E_j,k.
  Eigen::MatrixXd mean(68, 3), basis(3 * 68, K);
  for (int k = 0; k < 68; ++k) {
    const int v = model.landmark_vertices[size_t(k)];
    mean.row(k) = model.topology.V.row(v);
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < Ka; ++j) basis(3 * k + c, j) = double(model.shape_basis(j, 3 * v + c)) * model.shape_stddev(j);
      for (int j = 0; j < Kb; ++j) {
        basis(3 * k + c, Ka + j) = double(model.expression_basis(j, 3 * v + c)) * model.expression_stddev(j);
      }
    }
  }
  const int P = 6 + K, M = 2 * 68 + K;
  const auto residuals = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd r(M);
    const Eigen::Matrix3d R = euler_rotation(x.head<3>());
    const Eigen::VectorXd s = basis * x.tail(K);
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d p = R * (mean.row(k).transpose() + s.segment<3>(3 * k)) + x.segment<3>(3);
      const Eigen::Vector3d q = camera.project(p);
      r(2 * k) = q.x() - target(k, 0);
      r(2 * k + 1) = q.y() - target(k, 1);
    }
    r.tail(K) = std::sqrt(options.regularisation) * x.tail(K);
    return r;
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(P);
  Eigen::VectorXd r = residuals(x);
  double cost = r.squaredNorm(), lambda = 1e-3;
  LandmarkFit out;
  bool converged = false;
  for (int it = 0; it < options.iterations && !converged; ++it) {
    Eigen::MatrixXd J(M, P);
    for (int p = 0; p < P; ++p) {
      const double h = p < 3 ? 1e-6 : 1e-4;  // radians; mm and standardised α
      Eigen::VectorXd xp = x;
      xp(p) += h;
      J.col(p) = (residuals(xp) - r) / h;
    }
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::MatrixXd A = JtJ;
      A.diagonal() += lambda * JtJ.diagonal().cwiseMax(1e-9);
      const Eigen::VectorXd step = A.ldlt().solve(-g);
      const Eigen::VectorXd r_new = residuals(x + step);
      if (r_new.squaredNorm() < cost) {
        x += step;
        r = r_new;
        const double previous = cost;
        cost = r.squaredNorm();
        lambda = std::max(lambda / 3, 1e-9);
        improved = true;
        converged = previous - cost < 1e-10 * previous;
      } else {
        lambda *= 10;
      }
    }
    out.iterations = it + 1;
    if (!improved) break;
  }
  out.rotation = x.head<3>();
  out.translation = x.segment<3>(3);
  out.alpha = x.segment(6, Ka);
  out.beta = x.tail(Kb);
  out.rms_px = std::sqrt(r.head(2 * 68).squaredNorm() / 68);
  return out;
}

}  // namespace bareskin
