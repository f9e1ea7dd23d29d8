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

}  // namespace bareskin
