#include "morphable/procrustes.h"

#include <Eigen/Geometry>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"

namespace bareskin {
namespace {

Eigen::Matrix3Xd points(const RowMatrixXf& X, Eigen::Index row) {
  return Eigen::Map<const Eigen::Matrix<float, 3, Eigen::Dynamic>>(X.row(row).data(), 3, X.cols() / 3).cast<double>();
}

}  // namespace

void GpaOptions::check() const {
  if (max_iterations < 1 || max_iterations > 1000)
    throw InvalidInput("Procrustes", "iterations must lie in [1, 1000]", "use e.g. 20 (default)");
  if (!(tolerance_mm >= 0)) throw InvalidInput("Procrustes", "the tolerance must be >= 0 mm", "use e.g. 1e-4 (default)");
}

GpaResult generalized_procrustes(RowMatrixXf& X, const Eigen::MatrixX3d& reference, const GpaOptions& options) {
  options.check();
  const Eigen::Index n = X.rows(), V = X.cols() / 3;
  GpaResult out;
  out.transforms.assign(size_t(n), Eigen::Matrix4d::Identity());
  Eigen::Matrix3Xd mean = reference.transpose();
  for (int it = 0; it < options.max_iterations; ++it) {
    parallel_for(0, n, [&](int64_t b, int64_t e) {
      for (int64_t i = b; i < e; ++i) {
        const Eigen::Matrix3Xd P = points(X, i);
        const Eigen::Matrix4d T = Eigen::umeyama(P, mean, options.scale);
        const Eigen::Matrix3Xd Q = (T.topLeftCorner<3, 3>() * P).colwise() + T.topRightCorner<3, 1>();
        Eigen::Map<Eigen::Matrix<float, 3, Eigen::Dynamic>>(X.row(i).data(), 3, V) = Q.cast<float>();
        out.transforms[size_t(i)] = T * out.transforms[size_t(i)];
      }
    }, 1);
    // New mean, in a fixed summation order, put back onto the reference frame.
    Eigen::Matrix3Xd next = Eigen::Matrix3Xd::Zero(3, V);
    for (Eigen::Index i = 0; i < n; ++i) next += points(X, i);
    next /= double(n);
    const Eigen::Matrix4d T = Eigen::umeyama(next, Eigen::Matrix3Xd(reference.transpose()), options.scale);
    next = ((T.topLeftCorner<3, 3>() * next).colwise() + T.topRightCorner<3, 1>()).eval();
    out.mean_change_mm = std::sqrt((next - mean).colwise().squaredNorm().mean());
    mean = next;
    out.iterations = it + 1;
    if (out.mean_change_mm < options.tolerance_mm) break;
  }
  return out;
}

}  // namespace bareskin
