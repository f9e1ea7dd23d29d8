#include "render/light.h"

#include <cmath>

#include "core/error.h"
#include "render/sh.h"

namespace bareskin {
namespace {

// a_l: the basis of sh.h is a_l times the standard real SH; Â_l: the clamped cosine's convolution constants.
constexpr double kA[3] = {M_PI, 2 * M_PI / 1.7320508075688772, 2 * M_PI / 2.8284271247461903};
constexpr double kAhat[3] = {M_PI, 2 * M_PI / 3, M_PI / 4};
int band(int i) { return i == 0 ? 0 : i < 4 ? 1 : 2; }

}  // namespace

Eigen::Vector3d equirect_direction(double x, double y, int width, int height) {
  const double theta = M_PI * (y + 0.5) / height, phi = 2 * M_PI * (x + 0.5) / width - M_PI;
  return {std::sin(theta) * std::sin(phi), std::cos(theta), std::sin(theta) * std::cos(phi)};
}

ShLight sh_from_direction(const Eigen::Vector3d& direction, const Eigen::Vector3d& intensity) {
  if (!direction.allFinite() || direction.norm() < 1e-12 || !intensity.allFinite())
    throw InvalidInput("--direction", "is not a finite non-zero direction", "give x,y,z, e.g. 0.3,0.5,1");
  // Radiance coefficients of a delta light: L_i = I Ŷ_i(l); irradiance over π: γ_i = Â_l L_i / (π a_l) · π.
  const auto Y = sh_basis(direction.normalized());
  ShLight g{};
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < 9; ++i) g[size_t(9 * c + i)] = kAhat[band(i)] * intensity[c] * Y[size_t(i)] / (kA[band(i)] * kA[band(i)]);
  return g;
}

ShLight sh_from_environment(const Image& env) {
  if (env.channels < 3 || env.width != 2 * env.height || env.height < 2)
    throw InvalidInput("", "an environment map must be equirectangular (width = 2 × height) RGB", "give a 2:1 HDR map");
  std::array<double, 27> integral{};
  for (int y = 0; y < env.height; ++y) {
    const double theta = M_PI * (y + 0.5) / env.height;
    const double dw = (M_PI / env.height) * (2 * M_PI / env.width) * std::sin(theta);  // solid angle of a texel
    for (int x = 0; x < env.width; ++x) {
      const auto Y = sh_basis(equirect_direction(x, y, env.width, env.height));
      for (int c = 0; c < 3; ++c) {
        const float L = env.at(x, y, c);
        if (!std::isfinite(L) || L < 0)
          throw InvalidInput("", "the environment map holds a negative or non-finite value", "give radiance ≥ 0");
        for (int i = 0; i < 9; ++i) integral[size_t(9 * c + i)] += L * Y[size_t(i)] * dw;
      }
    }
  }
  ShLight g{};
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < 9; ++i)
      g[size_t(9 * c + i)] = kAhat[band(i)] * integral[size_t(9 * c + i)] / (M_PI * kA[band(i)] * kA[band(i)]);
  return g;
}

Image environment_from_sh(const ShLight& g, int width) {
  if (width < 4 || width % 2) throw InvalidInput("", "an environment map needs an even width ≥ 4", "");
  Image env(width, width / 2, 3, ColorSpace::Linear);
  for (int y = 0; y < env.height; ++y)
    for (int x = 0; x < env.width; ++x) {
      const auto Y = sh_basis(equirect_direction(x, y, env.width, env.height));
      for (int c = 0; c < 3; ++c) {
        double L = 0;  // L(ω) = π Σ γ_i basis_i(ω) / Â_l
        for (int i = 0; i < 9; ++i) L += M_PI * g[size_t(9 * c + i)] * Y[size_t(i)] / kAhat[band(i)];
        env.at(x, y, c) = float(L);
      }
    }
  return env;
}

KeyLight dominant_light(const ShLight& g) {
  const double w[3] = {0.2126, 0.7152, 0.0722};
  // Band 1 of sh.h is [−k1 y, k1 z, −k1 x]: the luminance's linear lobe points along (−γ3, −γ1, γ2).
  Eigen::Vector3d lum = Eigen::Vector3d::Zero();
  for (int c = 0; c < 3; ++c) lum += w[c] * Eigen::Vector3d(-g[size_t(9 * c + 3)], -g[size_t(9 * c + 1)], g[size_t(9 * c + 2)]);
  KeyLight key;
  if (lum.norm() < 1e-12) return key;
  key.direction = lum.normalized();
  // For a key light, (−γ3, −γ1, γ2)_c = Â_1 I_c c_1 l / a_1 (c_1 = √3 / √(4π)).
  const double c1 = std::sqrt(3.0 / (4 * M_PI));
  for (int c = 0; c < 3; ++c) {
    const Eigen::Vector3d v(-g[size_t(9 * c + 3)], -g[size_t(9 * c + 1)], g[size_t(9 * c + 2)]);
    key.intensity[c] = std::max(0.0, v.dot(key.direction)) * kA[1] / (kAhat[1] * c1);
  }
  return key;
}

}  // namespace bareskin
