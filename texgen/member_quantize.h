// The 8-bit value of a baked map texel in make-dataset's members. The members were first made through 16-bit PNG
// files of the bake (diffuse sRGB-encoded) cut to 8 bits, and keep those bytes:
//   b(v) = round(255 · round(65535 · clamp(g(v), 0, 1)) / 65535),  g = linear_to_srgb (colour) or the identity.
// b is non-decreasing in v, so it is the number of the 255 thresholds t_1..t_255 (the smallest float with b ≥ k) that
// v reaches: a table of the thresholds gives b without a pow and two roundings per texel (4K maps: 134 M texels).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

namespace bareskin::texgen {

class MemberQuantizer {
 public:
  explicit MemberQuantizer(bool srgb);
  uint8_t operator()(float v) const;  // b(v); v ≤ 0 or NaN: b(0); v ≥ 1: b(1)
  // The formula itself (the table's oracle).
  static uint8_t direct(float v, bool srgb);
  // The shared instances (built once).
  static const MemberQuantizer& colour();
  static const MemberQuantizer& data();

 private:
  bool srgb_;
  uint8_t low_ = 0, high_ = 255;           // b(0), b(1)
  std::array<uint32_t, 257> threshold_{};  // bit patterns of t_k (k = 1..255); t_256 = past 1.0
  std::vector<uint8_t> bucket_;            // per (bits >> 14) of the floats in [0, 1]: b at the bucket's first float
};

}  // namespace bareskin::texgen
