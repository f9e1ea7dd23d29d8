// A 3D similarity transform, x' = s R x + t: how a scan, a COLMAP model or a reference sits in another frame.
#pragma once
#include <Eigen/Core>

namespace bareskin {

struct Similarity {
  double s = 1;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  Eigen::Vector3d apply(const Eigen::Vector3d& x) const { return s * R * x + t; }
};

// The rows of V (points) under the 4x4 affine T, x' = A x + b: what Eigen::umeyama returns.
inline Eigen::MatrixX3d transformed(const Eigen::Matrix4d& T, const Eigen::MatrixX3d& V) {
  return ((V * T.topLeftCorner<3, 3>().transpose()).rowwise() + T.topRightCorner<3, 1>().transpose()).eval();
}

}  // namespace bareskin
