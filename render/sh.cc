#include "render/sh.h"

#include <cmath>

namespace bareskin {

ShScales sh_scales() {
  const double a0 = M_PI, a1 = 2 * M_PI / std::sqrt(3.0), a2 = 2 * M_PI / std::sqrt(8.0);
  const double c0 = 1 / std::sqrt(4 * M_PI), c1 = std::sqrt(3.0) / std::sqrt(4 * M_PI),
               c2 = 3 * std::sqrt(5.0) / std::sqrt(12 * M_PI);
  return {a0 * c0, a1 * c1, a2 * c2};
}

std::array<double, 9> sh_basis(const Eigen::Vector3d& n) {
  const auto [k0, k1, k2] = sh_scales();
  const double x = n.x(), y = n.y(), z = n.z();
  return {k0, -k1 * y, k1 * z, -k1 * x, k2 * x * y, -k2 * y * z, 0.5 * k2 / std::sqrt(3.0) * (3 * z * z - 1), -k2 * x * z,
          0.5 * k2 * (x * x - y * y)};
}

Eigen::Vector3d sh_irradiance(const Eigen::Vector3d& n, const double* gamma) {
  const std::array<double, 9> Y = sh_basis(n);
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (int c = 0; c < 3; ++c)
    for (int k = 0; k < 9; ++k) e[c] += Y[size_t(k)] * gamma[9 * c + k];
  return e;
}

}  // namespace bareskin
