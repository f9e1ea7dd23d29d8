#include "texgen/member_quantize.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/image.h"

namespace bareskin::texgen {
namespace {

constexpr uint32_t kOneBits = 0x3F800000u;  // 1.0f
constexpr int kBucketShift = 14;

uint32_t bits_of(float v) {
  uint32_t u;
  std::memcpy(&u, &v, sizeof(u));
  return u;
}

float float_of(uint32_t u) {
  float v;
  std::memcpy(&v, &u, sizeof(v));
  return v;
}

}  // namespace

uint8_t MemberQuantizer::direct(float v, bool srgb) {
  if (!(v > 0)) v = 0;  // NaN as 0
  if (srgb) v = linear_to_srgb(v);
  const float q16 = float(std::lround(std::clamp(v, 0.f, 1.f) * 65535.f)) * (1.0f / 65535.f);
  return uint8_t(std::lround(std::clamp(q16, 0.f, 1.f) * 255.f));
}

MemberQuantizer::MemberQuantizer(bool srgb) : srgb_(srgb) {
  // Non-negative floats order like their bit patterns: t_k by bisection over the patterns of [0, 1].
  low_ = direct(0, srgb);
  high_ = direct(1, srgb);
  const uint8_t lowest = low_;
  for (int k = 0; k <= 256; ++k) {
    if (k <= lowest) {
      threshold_[size_t(k)] = 0;
      continue;
    }
    uint32_t lo = 0, hi = kOneBits + 1;  // b(lo) < k; hi: first pattern with b ≥ k (past 1.0 when none)
    while (hi - lo > 1) {
      const uint32_t mid = lo + (hi - lo) / 2;
      (direct(float_of(mid), srgb) >= k ? hi : lo) = mid;
    }
    threshold_[size_t(k)] = hi;
  }
  bucket_.resize((kOneBits >> kBucketShift) + 1);
  for (size_t b = 0; b < bucket_.size(); ++b) bucket_[b] = direct(float_of(uint32_t(b) << kBucketShift), srgb);
}

uint8_t MemberQuantizer::operator()(float v) const {
  if (!(v > 0)) return low_;
  const uint32_t u = bits_of(v);
  if (u >= kOneBits) return high_;
  int b = bucket_[u >> kBucketShift];
  while (b < 255 && u >= threshold_[size_t(b) + 1]) ++b;
  return uint8_t(b);
}

const MemberQuantizer& MemberQuantizer::colour() {
  static const MemberQuantizer q(true);
  return q;
}

const MemberQuantizer& MemberQuantizer::data() {
  static const MemberQuantizer q(false);
  return q;
}

}  // namespace bareskin::texgen
