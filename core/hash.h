// Integer lattice hashing for seeded procedural textures (skin pores and pigment, makeup shimmer): the same seed and
// lattice point give the same value on every machine, with no state, so textures are reproducible per texel. And
// FNV-1a over bytes, for seeds and cache keys.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <initializer_list>

namespace bareskin {

// A 32-bit hash of integer lattice coordinates (up to three) under `seed`: each coordinate is multiplied into the
// state and mixed (MurmurHash3's constants), then the state is finalised with MurmurHash3's fmix32.
inline uint32_t lattice_hash(uint32_t seed, std::initializer_list<int> coordinates) {
  constexpr uint32_t kMultiplier[3] = {0x85ebca6bu, 0xc2b2ae35u, 0x27d4eb2fu};
  uint32_t h = seed ^ 0x9e3779b9u;
  int k = 0;
  for (const int c : coordinates) {
    if (k > 0) h = (h << 13 | h >> 19) * 5u + 0xe6546b64u;
    h ^= uint32_t(c) * kMultiplier[k++];
  }
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  h *= 0xc2b2ae35u;
  h ^= h >> 16;
  return h;
}

// 64-bit FNV-1a over `bytes` bytes, continuing from `h` (the FNV offset basis for a fresh hash): chain calls to hash
// several buffers as one. Stable across machines of one byte order; used for seeds and cache keys, not security.
constexpr uint64_t kFnv1aBasis = 1469598103934665603ull;
inline uint64_t fnv1a(const void* data, size_t bytes, uint64_t h = kFnv1aBasis) {
  const auto* p = static_cast<const unsigned char*>(data);
  for (size_t k = 0; k < bytes; ++k) h = (h ^ p[k]) * 1099511628211ull;
  return h;
}

// The hash's top 24 bits as a float in [0, 1).
inline float unit_float(uint32_t h) { return float(h >> 8) * (1.0f / 16777216.0f); }

// Hermite step from 0 at `edge0` to 1 at `edge1`.
inline float smoothstep(float edge0, float edge1, float x) {
  const float t = std::clamp((x - edge0) / (edge1 - edge0), 0.0f, 1.0f);
  return t * t * (3 - 2 * t);
}

}  // namespace bareskin
