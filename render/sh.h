// Order-2 spherical-harmonics lighting as in Deep3DFaceRecon (and BareSkinNet): 9 basis functions of the unit normal,
// each pre-multiplied by the Lambertian convolution constant of its band (a0 = π, a1 = 2π/√3, a2 = 2π/√8) and its
// normalisation (c0 = 1/√(4π), c1 = √3/√(4π), c2 = 3√5/√(12π)); γ holds 27 coefficients (9 per RGB channel) and the
// colour is albedo × (Y(n) · γ_c). Deep3DFaceRecon adds 0.8 to the first coefficient of each channel before use
// (`kDeep3dAmbient`); these functions take γ as given.
#pragma once
#include <Eigen/Core>
#include <array>

namespace bareskin {

constexpr double kDeep3dAmbient = 0.8;

// The band scales k_l = a_l c_l: the basis is [k0, −k1 y, k1 z, −k1 x, k2 xy, −k2 yz, k2 (3z² − 1) / (2√3), −k2 xz,
// k2 (x² − y²) / 2] (the Torch ops build the same from these).
struct ShScales {
  double k0, k1, k2;
};
ShScales sh_scales();

// The 9 basis values at unit normal n (x, y, z in the camera or world frame the coefficients are defined in).
std::array<double, 9> sh_basis(const Eigen::Vector3d& n);

// Irradiance (RGB) at normal n: Y(n) · γ_c per channel; gamma is 27 numbers: channel-major (R's 9, G's 9, B's 9).
Eigen::Vector3d sh_irradiance(const Eigen::Vector3d& n, const double* gamma);

}  // namespace bareskin
