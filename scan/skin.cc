#include "scan/skin.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/hash.h"
#include "core/mesh.h"

namespace bareskin {
namespace {

using Vec3 = Eigen::Vector3f;
using Vec2 = Eigen::Vector2f;

// Absorption per linear RGB channel, fitted to sRGB skin swatches (melanin 0.04 about (233,196,184), 0.6 about
// (91,57,43)); haemoglobin absorbs green and blue, barely red.
const Vec3 kBase(0.95f, 0.72f, 0.62f);
const Vec3 kMelanin(3.68f, 4.67f, 5.32f);
const Vec3 kHaemoglobin(0.15f, 1.6f, 1.0f);

uint32_t hash3(int x, int y, int z, uint32_t seed) { return lattice_hash(seed, {x, y, z}); }

// Value noise in [-1,1] with quintic interpolation (C2), and its exact gradient; deterministic in the seed.
float value_noise(const Vec3& p, uint32_t seed, Vec3* gradient = nullptr) {
  const float fx = std::floor(p.x()), fy = std::floor(p.y()), fz = std::floor(p.z());
  const int ix = int(fx), iy = int(fy), iz = int(fz);
  const float x = p.x() - fx, y = p.y() - fy, z = p.z() - fz;
  const auto fade = [](float t) { return t * t * t * (t * (t * 6 - 15) + 10); };
  const auto dfade = [](float t) { return 30 * t * t * (t - 1) * (t - 1); };
  const float u = fade(x), v = fade(y), w = fade(z);
  const auto c = [&](int a, int b, int d) { return 2 * unit_float(hash3(ix + a, iy + b, iz + d, seed)) - 1; };
  const float a = c(0, 0, 0), b = c(1, 0, 0), cc = c(0, 1, 0), d = c(1, 1, 0), e = c(0, 0, 1), f = c(1, 0, 1),
              g = c(0, 1, 1), h = c(1, 1, 1);
  const float k1 = b - a, k2 = cc - a, k3 = e - a, k4 = a - b - cc + d, k5 = a - cc - e + g, k6 = a - b - e + f,
              k7 = -a + b + cc - d + e - f - g + h;
  if (gradient) {
    *gradient = Vec3(dfade(x) * (k1 + k4 * v + k6 * w + k7 * v * w), dfade(y) * (k2 + k5 * w + k4 * u + k7 * w * u),
                     dfade(z) * (k3 + k6 * u + k5 * v + k7 * u * v));
  }
  return a + k1 * u + k2 * v + k3 * w + k4 * u * v + k5 * v * w + k6 * w * u + k7 * u * v * w;
}

// Fractal sum of `octaves` noises from `scale` mm down by halves; octaves finer than the footprint fade out.
// With `gradient`, also its gradient in mm^-1.
float fbm(const Vec3& p, float scale, int octaves, float footprint, uint32_t seed, Vec3* gradient = nullptr) {
  float sum = 0, amplitude = 0.5f;
  if (gradient) gradient->setZero();
  for (int o = 0; o < octaves; ++o, scale *= 0.5f, amplitude *= 0.5f) {
    const float keep = smoothstep(1.0f, 0.5f, footprint / scale);
    if (keep <= 0) break;
    Vec3 g;
    sum += keep * amplitude * value_noise(p / scale, seed + uint32_t(o) * 7919u, gradient ? &g : nullptr);
    if (gradient) *gradient += keep * amplitude / scale * g;
  }
  return sum;
}

// Spots on a jittered grid of `cell` mm: each cell holds one with probability `density`, radius in [0.5,1] * `radius`.
// Returns the coverage in [0,1] (soft edge 20% of the radius), widened by the footprint.
float spots(const Vec3& p, float cell, float radius, float density, float footprint, uint32_t seed) {
  const Vec3 q = p / cell;
  const int bx = int(std::floor(q.x() - 0.5f)), by = int(std::floor(q.y() - 0.5f)), bz = int(std::floor(q.z() - 0.5f));
  float best = 0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int d = 0; d < 2; ++d) {
        const uint32_t h = hash3(bx + a, by + b, bz + d, seed);
        if (unit_float(h) >= density) continue;
        const Vec3 centre(float(bx + a) + unit_float(hash3(h, 1, 0, seed)), float(by + b) + unit_float(hash3(h, 2, 0, seed)),
                          float(bz + d) + unit_float(hash3(h, 3, 0, seed)));
        const float r = radius * (0.5f + 0.5f * unit_float(hash3(h, 4, 0, seed)));
        const float soft = 0.2f * r + footprint;
        const float dist = (centre * cell - p).norm();
        best = std::max(best, smoothstep(r + soft, r - soft, dist) * r * r / (r * r + footprint * footprint));
      }
  return best;
}

float segment_distance(const Vec3& p, const Vec3& a, const Vec3& b, float* t_out = nullptr) {
  const Vec3 ab = b - a;
  const float t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12f), 0.0f, 1.0f);
  if (t_out) *t_out = t;
  return (a + t * ab - p).norm();
}

// Signed distance from `q` to a closed polygon (negative inside), in the polygon's units.
float polygon_signed_distance(const std::vector<Vec2>& poly, const Vec2& q) {
  float d = std::numeric_limits<float>::max();
  bool inside = false;
  for (size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Vec2 a = poly[j], b = poly[i], ab = b - a;
    const float t = std::clamp((q - a).dot(ab) / std::max(ab.squaredNorm(), 1e-20f), 0.0f, 1.0f);
    d = std::min(d, (a + t * ab - q).norm());
    if ((a.y() > q.y()) != (b.y() > q.y()) && q.x() < a.x() + (q.y() - a.y()) / (b.y() - a.y()) * ab.x()) inside = !inside;
  }
  return inside ? -d : d;
}

}  // namespace

std::map<std::string, double> Appearance::to_map() const {
  std::map<std::string, double> m{{"melanin", melanin},       {"haemoglobin", haemoglobin}, {"freckles", freckles},
          {"blush", blush},           {"lip_redness", lip_redness}, {"oiliness", oiliness},
          {"pore_scale", pore_scale}, {"wrinkles", wrinkles},       {"hair_r", hair.x()},
          {"hair_g", hair.y()},       {"hair_b", hair.z()},         {"iris_r", iris.x()},
          {"iris_g", iris.y()},       {"iris_b", iris.z()}};
  if (detail > 0) m["detail"] = detail;  // written only when used: scans without it keep their identity files
  return m;
}

Appearance sample_appearance(uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Appearance a;
  a.seed = seed;
  a.melanin = 0.02 * std::pow(30.0, u(rng));  // log-uniform over [0.02, 0.6]
  a.haemoglobin = 0.03 + 0.05 * u(rng);
  const double lightness = 1 - std::log(a.melanin / 0.02) / std::log(30.0);  // 1 lightest .. 0 darkest
  a.freckles = u(rng) < 0.6 * lightness ? 0.15 + 0.5 * u(rng) : 0.0;
  a.blush = 0.3 + 0.9 * u(rng);
  a.lip_redness = 0.6 + 0.8 * u(rng);
  a.oiliness = u(rng);
  a.pore_scale = 0.8 + 0.4 * u(rng);
  a.wrinkles = u(rng);
  // Brows: a brown tint well darker than the skin, from near black to (on light skin, sometimes) light brown.
  const double shade = 0.12 + (u(rng) < 0.4 * lightness ? 0.3 : 0.15) * u(rng);
  for (int c = 0; c < 3; ++c) {
    const double skin = kBase[c] * std::exp(-(a.melanin * kMelanin[c] + a.haemoglobin * kHaemoglobin[c]));
    a.hair[c] = shade * skin * (1.0 - 0.15 * c);
  }
  // Irises: brown of varying depth; blue-grey now and then on light skin.
  const bool blue = u(rng) < 0.5 * lightness;
  a.iris = (blue ? Eigen::Vector3d(0.05, 0.08, 0.12) : Eigen::Vector3d(0.07, 0.035, 0.015)) * (0.6 + 0.8 * u(rng));
  return a;
}

SkinModel::SkinModel(const TemplateFace& face, const Appearance& appearance)
    : appearance_(appearance), seed_(uint32_t(appearance.seed ^ (appearance.seed >> 32))) {
  if (face.landmark_vertices.size() != 68) {
    throw InvalidInput("template", "the skin model needs the 68 iBUG landmark vertices", "give a landmark file");
  }
  Eigen::MatrixX2d uv;
  if (!per_vertex_uv(face.mesh, uv)) {
    throw InvalidInput("template", "the skin model needs one UV per vertex (no seams)", "use a seamless template UV");
  }
  for (int k = 0; k < 68; ++k) landmarks_[size_t(k)] = face.mesh.V.row(face.landmark_vertices[size_t(k)]).cast<float>();
  for (int k = 48; k < 60; ++k) lip_polygon_.push_back(uv.row(face.landmark_vertices[size_t(k)]).cast<float>());
  for (int side = 0; side < 2; ++side) {
    eye_centre_[side] = Vec3::Zero();
    for (int k = 36 + 6 * side; k < 42 + 6 * side; ++k) {
      eye_polygon_[side].push_back(uv.row(face.landmark_vertices[size_t(k)]).cast<float>());
      if (k % 6 != 0 && k % 6 != 3) eye_centre_[side] += landmarks_[size_t(k)] / 4;  // the four lid points
    }
  }
  double area_uv = 0;
  for (Eigen::Index f = 0; f < face.mesh.F.rows(); ++f) {
    const Eigen::Vector2d a = uv.row(face.mesh.F(f, 0)), b = uv.row(face.mesh.F(f, 1)), c = uv.row(face.mesh.F(f, 2));
    area_uv += 0.5 * std::abs((b - a).x() * (c - a).y() - (c - a).x() * (b - a).y());
  }
  uv_to_mm_ = float(std::sqrt(surface_area(face.mesh.V, face.mesh.F) / std::max(area_uv, 1e-12)));
  brow_top_y_ = -1e9f;
  for (int k = 17; k <= 26; ++k) brow_top_y_ = std::max(brow_top_y_, landmarks_[size_t(k)].y());
  face_mid_x_ = 0.5f * (landmarks_[27].x() + landmarks_[8].x());
  cheek_[0] = (landmarks_[2] + landmarks_[31] + landmarks_[41]) / 3;
  cheek_[1] = (landmarks_[14] + landmarks_[35] + landmarks_[46]) / 3;
}

float SkinModel::lips(const Vec2& uv) const {
  const float d = polygon_signed_distance(lip_polygon_, uv) * uv_to_mm_;
  return smoothstep(0.8f, -0.8f, d);
}

float SkinModel::brows(const Vec3& p) const {
  float best = 0;
  for (int side = 0; side < 2; ++side) {
    const int first = side == 0 ? 17 : 22;
    const int medial = side == 0 ? 21 : 22;  // thicker towards the nose
    for (int k = first; k < first + 4; ++k) {
      float t;
      const Vec3 down(0, -1.5f, 0);
      const float d = segment_distance(p, landmarks_[size_t(k)] + down, landmarks_[size_t(k + 1)] + down, &t);
      const float along = std::abs(float(k) + t - float(medial)) / 4.0f;  // 0 medial .. 1 lateral
      const float half_width = 4.5f - 2.5f * along;
      best = std::max(best, smoothstep(half_width + 1.0f, half_width - 1.0f, d));
    }
  }
  return best;
}

float SkinModel::eyes(const Vec2& uv, const Vec3& p, Vec3* colour) const {
  for (int side = 0; side < 2; ++side) {
    const float d = polygon_signed_distance(eye_polygon_[side], uv) * uv_to_mm_;  // < 0 inside the lids
    if (d > 1.5f) continue;
    // Lash line: a dark band along the lid contour, widest on the upper lid; inside, sclera → iris → pupil.
    const float r = (p - eye_centre_[side]).norm();
    const float iris = smoothstep(5.8f, 5.2f, r), pupil = smoothstep(2.0f, 1.5f, r);
    Vec3 inside = (1 - iris) * Vec3(0.62f, 0.58f, 0.55f) + iris * appearance_.iris.cast<float>();
    inside = (1 - pupil) * inside + pupil * Vec3(0.01f, 0.01f, 0.01f);
    const bool upper = p.y() > eye_centre_[side].y();
    const float lash = smoothstep(upper ? 1.3f : 0.7f, 0.2f, std::abs(d + 0.2f));
    *colour = (1 - lash) * inside + lash * Vec3(0.02f, 0.015f, 0.012f);
    return std::max(smoothstep(0.3f, -0.3f, d), lash);
  }
  return 0;
}

float SkinModel::nose(const Vec3& p) const {
  const float bridge = smoothstep(9.0f, 5.0f, segment_distance(p, landmarks_[27], landmarks_[30]));
  const float alae = smoothstep(12.0f, 7.0f, segment_distance(p, landmarks_[31], landmarks_[35]));
  return std::max(bridge, alae);
}

float SkinModel::forehead(const Vec3& p) const { return smoothstep(brow_top_y_, brow_top_y_ + 20, p.y()); }

float SkinModel::t_zone(const Vec3& p) const {
  const float centre = smoothstep(50.0f, 15.0f, std::abs(p.x() - face_mid_x_));
  return std::max(nose(p), forehead(p) * centre);
}

float SkinModel::cheeks(const Vec3& p) const {
  const float r2 = 2 * 16.0f * 16.0f;
  return std::exp(-(p - cheek_[0]).squaredNorm() / r2) + std::exp(-(p - cheek_[1]).squaredNorm() / r2);
}

// Pores: at most one Gaussian dimple per cell of a jittered grid (cell 0.45 mm * pore_scale, sigma 0.06 mm). The
// texel filter is a Gaussian of sigma footprint/2, so the filtered dimple is a Gaussian of sigma' = sqrt(s^2 + (f/2)^2)
// with its amplitude scaled by s^2 / sigma'^2 (exact for a locally flat surface).
SkinModel::Pores SkinModel::pores(const Vec3& p, float footprint) const {
  const float cell = 0.45f * float(appearance_.pore_scale), s = 0.06f * float(appearance_.pore_scale);
  const float s2 = s * s + 0.25f * footprint * footprint, gain = s * s / s2;
  const Vec3 q = p / cell;
  const int bx = int(std::floor(q.x() - 0.5f)), by = int(std::floor(q.y() - 0.5f)), bz = int(std::floor(q.z() - 0.5f));
  Pores out{0, Vec3::Zero()};
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int d = 0; d < 2; ++d) {
        const uint32_t h = hash3(bx + a, by + b, bz + d, seed_ ^ 0x706f7265u);
        const Vec3 centre(float(bx + a) + unit_float(h), float(by + b) + unit_float(hash3(h, 1, 0, 0)),
                          float(bz + d) + unit_float(hash3(h, 2, 0, 0)));
        const float strength = 0.5f + 0.5f * unit_float(hash3(h, 3, 0, 0));
        const Vec3 r = p - centre * cell;
        const float value = gain * strength * std::exp(-r.squaredNorm() / (2 * s2));
        out.value += value;
        out.gradient -= value / s2 * r;
      }
  return out;
}

SkinSample SkinModel::sample(const Vec3& p, const Vec2& uv, float footprint) const {
  const Appearance& a = appearance_;
  const float lip = lips(uv), brow = brows(p), nose_mask = nose(p), tz = t_zone(p), cheek = std::min(1.0f, cheeks(p));
  const float nose_tip = std::exp(-(p - landmarks_[30]).squaredNorm() / (2 * 8.0f * 8.0f));
  const Pores pore = pores(p, footprint);
  SkinSample out;

  // Relief gradient: pores 0.07 mm deep, forehead grooves up to 0.06 mm, micro-relief 0.012 mm.
  const float pore_depth = 0.07f * (0.6f + 0.8f * std::min(1.0f, nose_mask + cheek)) * (1 - lip) * (1 - 0.7f * brow);
  out.relief_gradient = -pore_depth * pore.gradient;
  // Forehead wrinkles: four wavy horizontal grooves of width w; filtered as a 1D Gaussian (w' = sqrt(w^2 + (f/2)^2)).
  const float w = 0.35f, w2 = w * w + 0.25f * footprint * footprint;
  const float wrinkle = 0.06f * float(a.wrinkles) * forehead(p) * smoothstep(45.0f, 25.0f, std::abs(p.x() - face_mid_x_)) * w /
                        std::sqrt(w2);
  if (wrinkle > 0) {
    for (int k = 0; k < 4; ++k) {
      const float phase = 6.283f * unit_float(hash3(k, 9, 9, seed_));
      const float y = brow_top_y_ + 10.0f + 5.5f * float(k) + 1.2f * std::sin(p.x() / 11.0f + phase);
      const float dy_dx = 1.2f / 11.0f * std::cos(p.x() / 11.0f + phase);
      const float groove = std::exp(-(p.y() - y) * (p.y() - y) / (2 * w2));
      // height -= wrinkle * groove; d groove / dy = -(y_p - y)/w2 * groove, d groove / dx = (y_p - y)/w2 * y'(x) * groove
      const float slope = (p.y() - y) / w2 * groove;
      out.relief_gradient += wrinkle * Vec3(-slope * dy_dx, slope, 0);
    }
  }
  Vec3 micro;
  fbm(p, 1.0f, 4, footprint, seed_ ^ 0x6d696372u, &micro);
  out.relief_gradient += 0.012f * micro;

  // Chromophores.
  float melanin = float(a.melanin) * std::exp(0.25f * fbm(p, 20.0f, 3, footprint, seed_ ^ 1u));
  const float freckle_mask = 0.3f + 0.7f * std::min(1.0f, nose_mask + cheek);
  melanin *= 1 + 1.6f * spots(p, 2.5f, 0.8f, float(a.freckles) * freckle_mask, footprint, seed_ ^ 2u);
  // Micro-detail (Appearance::detail): what a rig's photos of real skin show at 0.1-0.3 mm per pixel and smooth
  // synthetic skin lacks — uneven pigment at 1-2 mm (solar lentigines), small ephelides on every complexion, a few
  // moles (naevi, 1-2.5 mm across, dark brown) and pores darkened by their pits' shadow (below).
  const float detail = float(a.detail) * (1 - lip) * (1 - brow);
  if (detail > 0) {
    melanin *= std::exp(0.45f * detail * fbm(p, 2.0f, 3, footprint, seed_ ^ 7u));
    melanin *= 1 + 1.3f * detail * spots(p, 1.6f, 0.35f, 0.3f * freckle_mask, footprint, seed_ ^ 8u);
    melanin *= 1 + 6.0f * detail * spots(p, 18.0f, 1.25f, 0.35f, footprint, seed_ ^ 9u);
  }
  melanin *= 1 - 0.1f * lip;
  float blood = float(a.haemoglobin) * std::exp(0.3f * fbm(p, 8.0f, 2, footprint, seed_ ^ 3u));
  blood *= 1 + float(a.blush) * (0.9f * cheek + 0.6f * nose_tip) + 4.0f * float(a.lip_redness) * lip;
  blood += 0.12f * spots(p, 14.0f, 1.2f, 0.15f, footprint, seed_ ^ 4u);  // blemishes

  Vec3 albedo = (kBase.array() * (-(melanin * kMelanin + blood * kHaemoglobin)).array().exp()).matrix();
  albedo *= 1 - (0.12f + 0.3f * detail) * std::min(1.0f, pore.value) * (1 - lip);
  // Brow hair: strands across the brow (noise stretched along x), coverage fading at the edges.
  // Strands are 0.25 mm across: they fade out when a texel is wider (low-pass, like every other component).
  const float strand_keep = smoothstep(1.0f, 0.25f, footprint / 0.25f);
  const float strands =
      0.5f + 0.5f * strand_keep * value_noise(Vec3(p.x() * 0.6f, p.y() * 4.0f, p.z() * 4.0f), seed_ ^ 5u);
  const float hair = brow * std::clamp(0.35f + 0.9f * strands, 0.0f, 1.0f);
  albedo = (1 - hair) * albedo + hair * a.hair.cast<float>();
  Vec3 eye_colour;
  const float eye = eyes(uv, p, &eye_colour);
  albedo = (1 - eye) * albedo + eye * eye_colour;

  const float wobble = fbm(p, 12.0f, 2, footprint, seed_ ^ 6u);
  const float oil = float(a.oiliness);
  out.material.diffuse = albedo;
  out.material.roughness =
      std::clamp(0.58f + 0.06f * wobble - (0.08f + 0.14f * oil) * tz + 0.05f * cheek - 0.22f * lip + 0.2f * hair - 0.45f * eye,
                 0.1f, 0.95f);
  out.material.specular =
      std::clamp(0.32f + 0.05f * wobble + (0.08f + 0.18f * oil) * tz - 0.06f * cheek + 0.12f * lip - 0.2f * hair + 0.3f * eye,
                 0.02f, 1.0f);
  return out;
}

}  // namespace bareskin
