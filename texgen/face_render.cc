#include "texgen/face_render.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include "core/error.h"
#include "core/image_io.h"
#include "render/sh.h"

namespace bareskin::texgen {
namespace fs = std::filesystem;

Surface rasterize_face(const Mesh& mesh, const Camera& camera) {
  Surface s;
  s.camera = camera;
  s.raster = rasterize_mesh(mesh, camera, true);
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> F = mesh.F, FUV = mesh.FUV;
  const Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor> UV = mesh.UV.cast<float>();
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> N = vertex_normals(mesh.V, mesh.F).cast<float>();
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> P = mesh.V.cast<float>();
  s.uv = interpolate(s.raster, FUV.data(), UV.data(), 2);
  s.normal = interpolate(s.raster, F.data(), N.data(), 3);
  s.position = interpolate(s.raster, F.data(), P.data(), 3);
  return s;
}

namespace {
float sample1(const Image& map, float u, float v) {
  if (map.width == 1 && map.height == 1) return map.pixels[0];
  return sample_bilinear(map, {u, v})[0];
}
}  // namespace

void shade(const Surface& s, const SurfaceMaps& maps, const Light& light, Image& out) {
  BS_CHECK(maps.diffuse && maps.roughness && maps.specular, "shade: maps missing");
  const int n = s.raster.width * s.raster.height;
  const Eigen::Vector3d eye = -s.camera.R.transpose() * s.camera.t;  // camera centre, world
  const Eigen::Vector3d l = light.direction.normalized();
  for (int i = 0; i < n; ++i) {
    if (!s.covered(size_t(i))) continue;
    const float u = s.uv[2 * size_t(i)], v = s.uv[2 * size_t(i) + 1];
    const Eigen::Vector3d nrm =
        Eigen::Vector3d(s.normal[3 * size_t(i)], s.normal[3 * size_t(i) + 1], s.normal[3 * size_t(i) + 2]).normalized();
    const Eigen::Vector3d p(s.position[3 * size_t(i)], s.position[3 * size_t(i) + 1], s.position[3 * size_t(i) + 2]);
    const Eigen::Vector3f albedo = sample_bilinear(*maps.diffuse, {u, v});
    const Eigen::Vector3d e = sh_irradiance(nrm, light.gamma.data());
    // Blinn-Phong key light from the dominant direction.
    double spec = 0;
    const double nl = nrm.dot(l);
    if (nl > 0 && light.specular > 0) {
      const double r = std::clamp(double(sample1(*maps.roughness, u, v)), 0.08, 1.0);
      const double exponent = std::clamp(2.0 / (r * r * r * r) - 2.0, 1.0, 4000.0);
      const Eigen::Vector3d h = (l + (eye - p).normalized()).normalized();
      const double nh = std::max(0.0, nrm.dot(h));
      spec = light.specular * sample1(*maps.specular, u, v) * (exponent + 8) / (8 * M_PI) * std::pow(nh, exponent) * nl;
    }
    for (int c = 0; c < 3; ++c)
      out.pixels[3 * size_t(i) + size_t(c)] = float(albedo[c] * e[c] + spec * light.colour[c]);
  }
}

Image sample_map(const Surface& s, const Image& map) {
  const int n = s.raster.width * s.raster.height;
  const int channels = std::min(map.channels, 3);
  Image out(s.raster.width, s.raster.height, channels, map.color_space);
  for (int i = 0; i < n; ++i) {
    if (!s.covered(size_t(i))) continue;
    const Eigen::Vector3f a = sample_bilinear(map, {s.uv[2 * size_t(i)], s.uv[2 * size_t(i) + 1]});
    for (int c = 0; c < channels; ++c) out.pixels[size_t(i) * channels + size_t(c)] = a[c];
  }
  return out;
}

// ---- backgrounds ----

namespace {

// Smooth value noise: a coarse random grid, bicubic-smoothstep interpolated, several octaves.
float value_noise(const std::vector<float>& grid, int g, double x, double y) {
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  const double sx = fx * fx * (3 - 2 * fx), sy = fy * fy * (3 - 2 * fy);
  const auto at = [&](int i, int j) { return grid[size_t(((j % g + g) % g) * g + ((i % g + g) % g))]; };
  return float((1 - sy) * ((1 - sx) * at(x0, y0) + sx * at(x0 + 1, y0)) + sy * ((1 - sx) * at(x0, y0 + 1) + sx * at(x0 + 1, y0 + 1)));
}

Eigen::Vector3f random_colour(Rng& rng) {
  // Muted, photo-like colours in linear light.
  const Eigen::Vector3f base(float(rng.uniform(0.02, 0.6)), float(rng.uniform(0.02, 0.6)), float(rng.uniform(0.02, 0.6)));
  const float grey = base.mean(), keep = float(rng.uniform(0.3, 1.0));
  return grey * Eigen::Vector3f::Ones() * (1 - keep) + base * keep;
}

}  // namespace

Image make_background(int size, const std::vector<BackgroundPhoto>& photos, Rng& rng, std::string* kind) {
  Image out(size, size, 3, ColorSpace::Linear);
  const double pick = rng.uniform();
  if (!photos.empty() && pick < 0.5) {
    const BackgroundPhoto& photo = photos[size_t(rng.below(int(photos.size())))];
    const Image& src = photo.linear;
    // A random crop, scaled 0.6-1.6x of the photo's shorter side onto the frame, maybe mirrored, dimmed or brightened.
    const double side = std::min(src.width, src.height) * rng.uniform(0.6, 1.0);
    const double x0 = rng.uniform(0, src.width - side), y0 = rng.uniform(0, src.height - side);
    const bool mirror = rng.chance(0.5);
    const float gain = float(rng.uniform(0.5, 1.3));
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        double sx = x0 + (x + 0.5) * side / size, sy = y0 + (y + 0.5) * side / size;
        if (mirror) sx = x0 + side - (sx - x0);
        const Eigen::Vector3f c =
            sample_bilinear(src, {sx / src.width, 1.0 - sy / src.height});
        for (int k = 0; k < 3; ++k) out.at(x, y, k) = gain * c[k];
      }
    if (kind) *kind = "photo:" + photo.name;
    return out;
  }
  const Eigen::Vector3f a = random_colour(rng), b = random_colour(rng);
  if (pick < 0.75) {
    const double angle = rng.uniform(0, 2 * M_PI), dx = std::cos(angle), dy = std::sin(angle);
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const double t = std::clamp(0.5 + ((x + 0.5) / size - 0.5) * dx + ((y + 0.5) / size - 0.5) * dy, 0.0, 1.0);
        for (int k = 0; k < 3; ++k) out.at(x, y, k) = float((1 - t) * a[k] + t * b[k]);
      }
    if (kind) *kind = "gradient";
    return out;
  }
  const int g = 16;
  std::vector<float> grid(g * g);
  for (float& v : grid) v = float(rng.uniform());
  const double scale = rng.uniform(2, 8);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      double t = 0, w = 0.5;
      for (int o = 0; o < 4; ++o, w *= 0.5) {
        const double f = scale * std::pow(2.0, o) / size;
        t += w * value_noise(grid, g, x * f + 3.1 * o, y * f + 1.7 * o);
      }
      t = std::clamp(t / 0.9375, 0.0, 1.0);
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = float((1 - t) * a[k] + t * b[k]);
    }
  if (kind) *kind = "noise";
  return out;
}

std::vector<BackgroundPhoto> read_background_photos(const std::string& folder) {
  std::vector<BackgroundPhoto> out;
  if (folder.empty() || !fs::is_directory(folder)) return out;
  // Textures and scenes without a human face (the detector must find only ours).
  for (const char* name : {"brick.png", "grass.png", "gravel.png", "coffee.png", "chelsea.png", "rocket.jpg",
                           "motorcycle_left.png", "hubble_deep_field.jpg", "coins.png", "color.png"}) {
    const fs::path p = fs::path(folder) / name;
    if (!fs::exists(p)) continue;
    try {
      Image img = read_image(p.string());
      Image rgb(img.width, img.height, 3, ColorSpace::Linear);
      for (size_t i = 0; i < size_t(img.width) * img.height; ++i)
        for (int c = 0; c < 3; ++c) {
          const float v = img.pixels[i * img.channels + size_t(std::min(c, img.channels - 1))];
          rgb.pixels[3 * i + size_t(c)] = img.color_space == ColorSpace::Linear ? v : srgb_to_linear(v);
        }
      if (img.width >= 64 && img.height >= 64) out.push_back({fs::path(name).stem().string(), std::move(rgb)});
    } catch (const Error&) {
      // an unreadable file there is not ours to fix: the procedural backgrounds remain
    }
  }
  return out;
}

// ---- the head around the face ----

void paint_head(Image& img, const std::vector<Eigen::Vector2d>& lm, const Eigen::Vector3f& skin,
                const Eigen::Vector3f& hair, Rng& rng) {
  using Vec = Eigen::Vector2d;
  Vec eye_r = Vec::Zero(), eye_l = Vec::Zero();
  for (int k = 36; k < 42; ++k) eye_r += lm[size_t(k)] / 6;
  for (int k = 42; k < 48; ++k) eye_l += lm[size_t(k)] / 6;
  const Vec mid = 0.5 * (eye_r + eye_l);
  const double d = std::max((eye_l - eye_r).norm(), 1.0);
  const Vec across = (eye_l - eye_r) / d, down(-across.y(), across.x());
  const Vec centre = 0.5 * (lm[0] + lm[16]);
  const double half = 0.5 * (lm[16] - lm[0]).norm();
  const double crown = rng.uniform(1.1, 1.5) * d, width = half * rng.uniform(1.12, 1.3), length = rng.uniform(1.6, 2.6) * d;
  const double neck = half * rng.uniform(0.6, 0.8);
  const Vec chin = lm[8];
  const float strand_phase = float(rng.uniform(0, 6.28)), strand_freq = float(rng.uniform(0.3, 0.7));
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const Vec p(x + 0.5, y + 0.5);
      const double u = (p - centre).dot(across), v = (p - mid).dot(down);  // across the face, down from the eyes
      Eigen::Vector3f c;
      bool paint = false;
      // Neck: below the jaw, darker (the chin's shadow) towards the top.
      const double below_chin = (p - chin).dot(down);
      if (std::abs(u) < neck && v > 0 && below_chin > -0.6 * d) {
        const float shade = float(std::clamp(0.45 + 0.25 * below_chin / d, 0.45, 0.8));
        c = skin * shade;
        paint = true;
      }
      // Ears: beside the face contour at eye to nose height.
      for (const Vec& side : {lm[1], lm[15]}) {
        const Vec q = p - (side + 0.12 * d * (side - centre).normalized() + 0.15 * d * down);
        const double a = q.dot(across) / (0.28 * d), b = q.dot(down) / (0.62 * d);
        if (a * a + b * b < 1) {
          c = skin * float(0.7 + 0.15 * a);
          paint = true;
        }
      }
      // Hair: an ellipse over the crown reaching down the sides, behind the ears at the top.
      const double hu = u / width, hv = (v + 0.35 * d) / (v < -0.35 * d ? crown + 0.35 * d : length);
      if (hu * hu + hv * hv < 1 && !(paint && v > 0.3 * d)) {
        const float strand = 0.75f + 0.25f * std::sin(strand_freq * float(u) + strand_phase + 0.05f * float(v));
        c = hair * strand;
        paint = true;
      }
      if (paint)
        for (int k = 0; k < 3; ++k) img.at(x, y, k) = c[k];
    }
}

// ---- occluders ----

Occluders draw_occluders(int size, const std::vector<Eigen::Vector2d>& landmarks, double probability, Rng& rng) {
  Occluders o;
  o.labels.width = o.labels.height = size;
  o.labels.label.assign(size_t(size) * size, 0);
  const auto skin_like = [&] {
    const double t = rng.uniform();
    return Eigen::Vector3f(float(0.55 - 0.45 * t), float(0.38 - 0.33 * t), float(0.28 - 0.25 * t));
  };
  const Eigen::Vector3f hair_colours[] = {{0.01f, 0.008f, 0.006f}, {0.05f, 0.025f, 0.012f}, {0.18f, 0.09f, 0.03f},
                                          {0.45f, 0.32f, 0.14f},  {0.25f, 0.06f, 0.02f},   {0.35f, 0.35f, 0.33f}};
  o.hair = hair_colours[rng.below(6)];
  o.frame = rng.chance(0.6) ? Eigen::Vector3f(0.01f, 0.01f, 0.012f) : random_colour(rng);
  o.hand = skin_like();
  o.hat = random_colour(rng);
  o.texture_seed = rng.next();
  if (!rng.chance(probability)) return o;
  std::mt19937_64 shape_rng(rng.next());
  const Occluder kinds[] = {Occluder::Hair, Occluder::Glasses, Occluder::Hand, Occluder::Hat};
  const int first = rng.below(4);
  const int count = rng.chance(0.2) ? 2 : 1;
  for (int k = 0; k < count; ++k) {
    const Occluder which = kinds[(first + k) % 4];
    draw_occluder(o.labels, which, landmarks, shape_rng);
    o.kinds.push_back(to_string(which));
  }
  return o;
}

Occluders warp_occluders(const Occluders& o, const detect::Similarity& sim, int size) {
  Occluders w = o;
  w.labels.width = w.labels.height = size;
  w.labels.label.assign(size_t(size) * size, 0);
  if (!o.any()) return w;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const Eigen::Vector2d p = sim.inverse({x + 0.5, y + 0.5});
      const int sx = int(std::floor(p.x())), sy = int(std::floor(p.y()));
      if (sx < 0 || sy < 0 || sx >= o.labels.width || sy >= o.labels.height) continue;
      w.labels.label[size_t(y) * size + x] = o.labels.label[size_t(sy) * o.labels.width + sx];
    }
  return w;
}

void paint_occluders(const Occluders& o, Image& img) {
  if (!o.any()) return;
  Rng rng(o.texture_seed);
  std::vector<float> strands(size_t(img.width));  // hair: per-column brightness streaks
  for (float& s : strands) s = float(rng.uniform(0.6, 1.4));
  for (int x = 1; x < img.width; ++x) strands[size_t(x)] = 0.6f * strands[size_t(x - 1)] + 0.4f * strands[size_t(x)];
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const uint8_t label = o.labels.label[size_t(y) * img.width + x];
      if (!label) continue;
      Eigen::Vector3f c;
      switch (label) {
        case kHair: c = o.hair * strands[size_t(x)] * float(0.8 + 0.4 * y / img.height); break;
        case kGlasses: c = o.frame; break;
        case kHand: c = o.hand * float(0.75 + 0.35 * x / img.width); break;
        case kHat: c = o.hat * float(0.85 + 0.3 * y / img.height); break;
        default: c = o.hat; break;
      }
      for (int k = 0; k < 3; ++k) img.at(x, y, k) = c[k];
    }
}

}  // namespace bareskin::texgen
