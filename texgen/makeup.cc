// Painting a look into one summed layer, and applying a layer to a subject's UV maps.
#include "texgen/makeup.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "core/hash.h"

namespace bareskin::makeup {
namespace {

uint32_t hash2(int x, int y, uint64_t seed) { return lattice_hash(uint32_t(seed ^ (seed >> 32)), {x, y}); }

// Pattern coverage in [0,1] at the point q (mm, already rotated), period P.
float pattern_mask(Pattern pattern, const Eigen::Vector2f& q, float P) {
  constexpr float kTwoPi = 6.2831853f;
  switch (pattern) {
    case Pattern::Solid:
      return 1;
    case Pattern::Stripes:
      return smoothstep(-0.25f, 0.25f, std::cos(kTwoPi * q.x() / P));
    case Pattern::Dots: {
      const Eigen::Vector2f c = q / P;
      const Eigen::Vector2f local(c.x() - std::floor(c.x()) - 0.5f, c.y() - std::floor(c.y()) - 0.5f);
      return smoothstep(0.34f, 0.26f, local.norm());
    }
    case Pattern::Zigzag: {
      const float t = q.x() / (1.5f * P);
      const float tri = std::abs(2 * (t - std::floor(t)) - 1);
      return smoothstep(-0.25f, 0.25f, std::cos(kTwoPi * (q.y() / P - 0.8f * tri)));
    }
  }
  return 1;
}

void check_layer(const LayerSpec& l) {
  const bool colour_ok = l.colour.allFinite() && l.colour.minCoeff() >= 0 &&
                         l.colour.maxCoeff() <= (l.mode == ColourMode::Absolute ? 1.0f : 4.0f);
  if (!colour_ok || !(l.opacity >= 0 && l.opacity <= 1) || !(l.feather_mm >= 0) ||
      !(l.shimmer >= 0 && l.shimmer <= 1) || !(std::abs(l.offset_mm) + 0.5f * l.feather_mm <= kMaxReachMm) ||
      !(l.pattern_period_mm > 0)) {
    throw InvalidInput(
        "makeup look", "layer '" + l.product + "' has a colour, opacity, feather, offset or shimmer out of range",
        "colours in [0,1] (skin factors in [0,4]), opacity and shimmer in [0,1], |offset| + feather/2 <= " +
            std::to_string(int(kMaxReachMm)) + " mm");
  }
}

// The bilinear footprint of texel-space point (x, y) (texel centres at +0.5), clamped, in a width × height image;
// sample() reads any channel of an image of that size through it.
struct Footprint {
  int x0, y0, x1, y1;
  float tx, ty;
  Footprint(float x, float y, int width, int height) {
    const float fx = std::clamp(x - 0.5f, 0.0f, float(width - 1)), fy = std::clamp(y - 0.5f, 0.0f, float(height - 1));
    x0 = int(fx), y0 = int(fy), x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
    tx = fx - float(x0), ty = fy - float(y0);
  }
  float sample(const Image& image, int c) const {
    return (1 - ty) * ((1 - tx) * image.at(x0, y0, c) + tx * image.at(x1, y0, c)) +
           ty * ((1 - tx) * image.at(x0, y1, c) + tx * image.at(x1, y1, c));
  }
};

// Bilinear lookup of channel c of `image` at texel-space point (x, y) (texel centres at +0.5), clamped.
float bilinear(const Image& image, float x, float y, int c) {
  return Footprint(x, y, image.width, image.height).sample(image, c);
}

}  // namespace

FinishDelta finish_delta(Finish finish) {
  switch (finish) {
    case Finish::Matte:
      return {0.2f, -0.15f};
    case Finish::Satin:
      return {-0.05f, 0.05f};
    case Finish::Gloss:
      return {-0.3f, 0.35f};
  }
  return {0, 0};
}

MakeupLayer paint(const MakeupRegions& regions, const MakeupLook& look, const Eigen::Vector3f& skin) {
  const int n = regions.uv_size;
  BS_CHECK(n > 0, "paint needs regions built by makeup_regions");
  if (!skin.allFinite() || skin.minCoeff() < 0 || skin.maxCoeff() > 1) {
    throw InvalidInput("makeup", "the skin tone is not a linear colour in [0,1]",
                       "pass skin_tone() of the bare albedo");
  }
  MakeupLayer out;
  Image premultiplied(n, n, 4, ColorSpace::Linear);  // C (premultiplied) and A, composited with "over"
  out.finish = Image(n, n, 2, ColorSpace::Data);
  const float mm = float(regions.mm_per_texel);
  for (const LayerSpec& l : look.layers) {
    check_layer(l);
    const Eigen::Vector3f colour =
        l.mode == ColourMode::Absolute ? l.colour : l.colour.cwiseProduct(skin).cwiseMin(1.0f);
    const FinishDelta fd = finish_delta(l.finish);
    const Image& distance = regions[l.region];
    const auto& box = regions.box[size_t(l.region)];
    const float c = std::cos(l.pattern_angle), s = std::sin(l.pattern_angle);
    const float half = std::max(0.5f * l.feather_mm, 1e-3f);
    for (int y = box[2]; y < box[3]; ++y)
      for (int x = box[0]; x < box[1]; ++x) {
        const float d = distance.at(x, y) - l.offset_mm;
        float cover = (1 - smoothstep(-half, half, d)) * regions.coverage.at(x, y) * (1 - regions.exclusion.at(x, y));
        if (cover <= 0) continue;
        if (l.pattern != Pattern::Solid) {
          const Eigen::Vector2f p((float(x) + 0.5f) * mm, (float(y) + 0.5f) * mm);
          cover *= pattern_mask(l.pattern, Eigen::Vector2f(c * p.x() + s * p.y(), -s * p.x() + c * p.y()),
                                l.pattern_period_mm);
        }
        Eigen::Vector3f col = colour;
        float dr = fd.roughness, ds = fd.specular;
        if (l.shimmer > 0) {  // flecks on a 0.3 mm grid
          const int gx = int(std::floor((float(x) + 0.5f) * mm / 0.3f)),
                    gy = int(std::floor((float(y) + 0.5f) * mm / 0.3f));
          if (unit_float(hash2(gx, gy, l.seed)) < 0.35f * l.shimmer) {
            col = (col * (1 + 1.5f * l.shimmer)).array() + 0.1f * l.shimmer;
            col = col.cwiseMin(1.0f);
            dr -= 0.25f * l.shimmer;
            ds += 0.5f * l.shimmer;
          }
        }
        const float a = l.opacity * cover;
        for (int k = 0; k < 3; ++k) premultiplied.at(x, y, k) = premultiplied.at(x, y, k) * (1 - a) + col[k] * a;
        premultiplied.at(x, y, 3) = premultiplied.at(x, y, 3) * (1 - a) + a;
        out.finish.at(x, y, 0) = std::clamp(out.finish.at(x, y, 0) + cover * dr, -1.0f, 1.0f);
        out.finish.at(x, y, 1) = std::clamp(out.finish.at(x, y, 1) + cover * ds, -1.0f, 1.0f);
      }
  }
  out.colour = Image(n, n, 4, ColorSpace::Linear);
  for (size_t i = 0; i < size_t(n) * n; ++i) {
    const float A = premultiplied.pixels[4 * i + 3];
    for (int k = 0; k < 3; ++k)
      out.colour.pixels[4 * i + k] = A > 0 ? std::min(1.0f, premultiplied.pixels[4 * i + k] / A) : 0;
    out.colour.pixels[4 * i + 3] = A;
  }
  return out;
}

Eigen::Vector3f skin_tone(const MakeupRegions& regions, const Image& diffuse_linear) {
  if (diffuse_linear.color_space != ColorSpace::Linear || diffuse_linear.channels < 3) {
    throw InvalidInput("diffuse", "the skin tone needs a linear RGB albedo", "convert with to_linear first");
  }
  const int n = regions.uv_size;
  const float sx = float(diffuse_linear.width) / float(n), sy = float(diffuse_linear.height) / float(n);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double count = 0;
  const Image& face = regions[Region::Face];
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      if (face.at(x, y) >= 0 || regions.coverage.at(x, y) <= 0) continue;
      for (int k = 0; k < 3; ++k) sum[k] += bilinear(diffuse_linear, (float(x) + 0.5f) * sx, (float(y) + 0.5f) * sy, k);
      count += 1;
    }
  if (count == 0)
    throw InvalidInput("makeup", "the face region is empty", "check the template's UV layout and landmarks");
  return (sum / count).cast<float>();
}

void apply_makeup(const MakeupLayer& layer, Image& diffuse, Image* roughness, Image* specular) {
  if (diffuse.color_space != ColorSpace::Linear || diffuse.channels < 3) {
    throw InvalidInput("diffuse", "makeup is applied to a linear RGB albedo", "convert with to_linear first");
  }
  const int n = layer.colour.width;
  // Premultiplied colour interpolates correctly across the layer's edges.
  Image premultiplied = layer.colour;
  for (size_t i = 0; i < size_t(n) * n; ++i)
    for (int k = 0; k < 3; ++k) premultiplied.pixels[4 * i + k] *= premultiplied.pixels[4 * i + 3];
  const bool same = diffuse.width == n && diffuse.height == n;
  parallel_for(0, diffuse.height, [&](int64_t y0, int64_t y1) {  // rows are independent: the same bytes on any pool
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < diffuse.width; ++x) {
        const float lx = (float(x) + 0.5f) * float(n) / float(diffuse.width),
                    ly = (float(y) + 0.5f) * float(n) / float(diffuse.height);
        const Footprint at(lx, ly, n, n);  // one footprint for the four channels
        const float A = same ? premultiplied.at(x, y, 3) : at.sample(premultiplied, 3);
        if (A <= 0) continue;
        for (int k = 0; k < 3; ++k) {
          const float C = same ? premultiplied.at(x, y, k) : at.sample(premultiplied, k);
          diffuse.at(x, y, k) = diffuse.at(x, y, k) * (1 - A) + C;
        }
      }
  }, 16);
  const auto apply_delta = [&](Image* map, int channel) {
    if (!map) return;
    const bool same_map = map->width == n && map->height == n;
    parallel_for(0, map->height, [&](int64_t y0, int64_t y1) {
      for (int y = int(y0); y < int(y1); ++y)
        for (int x = 0; x < map->width; ++x) {
          const float d = same_map ? layer.finish.at(x, y, channel)
                                   : bilinear(layer.finish, (float(x) + 0.5f) * float(n) / float(map->width),
                                              (float(y) + 0.5f) * float(n) / float(map->height), channel);
          map->at(x, y, 0) = std::clamp(map->at(x, y, 0) + d, 0.0f, 1.0f);
        }
    }, 16);
  };
  apply_delta(roughness, 0);
  apply_delta(specular, 1);
}

Image layer_png_image(const MakeupLayer& layer) { return to_srgb(layer.colour); }

Image finish_png_image(const MakeupLayer& layer) {
  Image out = layer.finish;
  for (float& v : out.pixels) v = (127.0f + 127.0f * std::clamp(v, -1.0f, 1.0f)) / 255.0f;  // 0 -> 127 exactly
  return out;
}

MakeupLayer layer_from_png_images(const Image& layer_png, const Image& finish_png) {
  if (layer_png.channels != 4 || finish_png.channels != 2 || layer_png.width != finish_png.width ||
      layer_png.height != finish_png.height) {
    throw InvalidInput("layer.png", "a makeup layer is an RGBA layer.png with a grey+alpha finish.png of the same size",
                       "write them with layer_png_image / finish_png_image");
  }
  MakeupLayer out;
  Image srgb = layer_png;
  srgb.color_space = ColorSpace::sRGB;
  out.colour = to_linear(srgb);
  out.finish = finish_png;
  out.finish.color_space = ColorSpace::Data;
  for (float& v : out.finish.pixels) v = std::clamp((255.0f * v - 127.0f) / 127.0f, -1.0f, 1.0f);
  return out;
}

Eigen::Vector3f linear_rgb_to_lab(const Eigen::Vector3f& rgb) {
  // IEC 61966-2-1 primaries, D65 white (Xn, Yn, Zn) = (0.95047, 1, 1.08883).
  const float X = 0.4124564f * rgb.x() + 0.3575761f * rgb.y() + 0.1804375f * rgb.z();
  const float Y = 0.2126729f * rgb.x() + 0.7151522f * rgb.y() + 0.0721750f * rgb.z();
  const float Z = 0.0193339f * rgb.x() + 0.1191920f * rgb.y() + 0.9503041f * rgb.z();
  const auto f = [](float t) {
    constexpr float d = 6.0f / 29.0f;
    return t > d * d * d ? std::cbrt(t) : t / (3 * d * d) + 4.0f / 29.0f;
  };
  const float fx = f(X / 0.95047f), fy = f(Y), fz = f(Z / 1.08883f);
  return {116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)};
}

float delta_e(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return (linear_rgb_to_lab(a) - linear_rgb_to_lab(b)).norm();
}

double mean_delta_e(const MakeupRegions& regions, Region region, const Image& before, const Image& after) {
  const int n = regions.uv_size;
  if (before.width != n || before.height != n || after.width != n || after.height != n || before.channels < 3 ||
      after.channels < 3) {
    throw InvalidInput("makeup", "ΔE needs two RGB maps of the regions' size",
                       "resample them to " + std::to_string(n) + "²");
  }
  const Image& distance = regions[region];
  double sum = 0;
  int64_t count = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      if (distance.at(x, y) >= 0 || regions.coverage.at(x, y) <= 0 || regions.exclusion.at(x, y) >= 0.5f) continue;
      sum += delta_e({before.at(x, y, 0), before.at(x, y, 1), before.at(x, y, 2)},
                     {after.at(x, y, 0), after.at(x, y, 1), after.at(x, y, 2)});
      ++count;
    }
  return count ? sum / double(count) : -1;
}

}  // namespace bareskin::makeup
