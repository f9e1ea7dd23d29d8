// Lights for relighting, all turned into the order-2 SH coefficients γ of render/sh.h (27 numbers, channel-major), so
// that a fitted photo light, an HDR environment and a key light shade the same way: colour = albedo × Y(n) · γ_c.
// Conventions (docs/relight.md): γ describes S(n) = E(n) / π, the irradiance over π, so a white environment of
// radiance 1 gives S = 1 (albedo comes back unchanged) and a key light of intensity I gives S ≈ I max(0, n · l)
// (order-2 SH of the clamped cosine). Directions are in the model frame (+x the face's left, +y up, +z out of the
// face), which is the front camera's frame. Equirectangular maps: row 0 is straight up (+y), column centres at
// azimuth φ = 2π (x + 0.5) / W − π with φ = 0 facing +z; direction (sin θ sin φ, cos θ, sin θ cos φ).
#pragma once
#include <Eigen/Core>
#include <array>

#include "core/image.h"

namespace bareskin {

using ShLight = std::array<double, 27>;

// The direction of an equirectangular pixel centre (x, y) of a width × height map.
Eigen::Vector3d equirect_direction(double x, double y, int width, int height);

// A key light from `direction` (towards the light, any length but non-zero) with RGB intensity `intensity`.
ShLight sh_from_direction(const Eigen::Vector3d& direction, const Eigen::Vector3d& intensity);
// The SH projection of an equirectangular radiance map (linear RGB, any size, 3+ channels): exact for a band-limited
// environment, the order-2 approximation of its irradiance otherwise. InvalidInput for a map that is not 2:1 or holds
// a negative or non-finite value.
ShLight sh_from_environment(const Image& equirect);
// The radiance whose irradiance the SH light is (band-wise deconvolution), as a width × width/2 equirectangular map,
// linear; negative lobes are kept (an order-2 light can dip below zero; engines clamp).
Image environment_from_sh(const ShLight& gamma, int width);

// The strongest direction of an SH light: band 1 of its luminance (0.2126 R + 0.7152 G + 0.0722 B), with the RGB
// intensity a key light from that direction would need to give that band (exact for sh_from_direction). A zero
// direction when band 1 is zero (a uniform light).
struct KeyLight {
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();  // unit, towards the light; zero: none
  Eigen::Vector3d intensity = Eigen::Vector3d::Zero();
};
KeyLight dominant_light(const ShLight& gamma);

}  // namespace bareskin
