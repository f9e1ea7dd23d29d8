#include "scan/capture.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/parallel.h"
#include "core/scan_folder.h"
#include "render/shade.h"
#include "scan/multiview.h"

namespace bareskin {
namespace {

uint64_t mix(uint64_t x) {  // splitmix64's finaliser
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

double unit(uint64_t h) { return double(h >> 11) * (1.0 / 9007199254740992.0); }  // [0,1)

// Dots on a jittered 3D grid of `cell` mm (one per cell with probability `density`): the grey of the nearest dot
// covering x (soft edge of a tenth of its radius), or -1 when none does.
double dots(const Eigen::Vector3d& x, double cell, double density, uint64_t seed) {
  const Eigen::Vector3d q = x / cell;
  const Eigen::Vector3i base(int(std::floor(q.x() - 0.5)), int(std::floor(q.y() - 0.5)), int(std::floor(q.z() - 0.5)));
  double grey = -1, best = 0;
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int c = 0; c < 2; ++c) {
        const Eigen::Vector3i k = base + Eigen::Vector3i(a, b, c);
        const uint64_t h = mix(seed ^ mix(uint64_t(uint32_t(k.x())) ^ mix(uint64_t(uint32_t(k.y())) << 1 ^
                                                                             mix(uint64_t(uint32_t(k.z())) << 2))));
        if (unit(h) >= density) continue;
        const Eigen::Vector3d centre = k.cast<double>() + Eigen::Vector3d(unit(mix(h + 1)), unit(mix(h + 2)), unit(mix(h + 3)));
        const double r = 0.2 + 0.25 * unit(mix(h + 4));  // radius in cells
        const double d = (q - centre).norm();
        const double cover = std::clamp((r - d) / (0.1 * r), 0.0, 1.0);
        if (cover > best) best = cover, grey = cover * unit(mix(h + 5)) + (1 - cover) * 0.35;
      }
  return grey;
}

}  // namespace

void CaptureOptions::check() const {
  if (photos < 2 || photos > 500) throw InvalidInput("--photos", "must lie in [2, 500]", "pass e.g. 24");
  if (size < 64 || size > 8192) throw InvalidInput("--size", "must lie in [64, 8192] px", "pass e.g. 1536");
  if (supersample < 1 || supersample > 4) throw InvalidInput("--supersample", "must lie in [1, 4]", "pass 1 or 2");
  if (!(field_mm > 0 && field_mm < 10000)) throw InvalidInput("--field", "must lie in (0, 10000) mm", "pass e.g. 320");
  if (!(distance > 0)) throw InvalidInput("capture", "the camera distance must be positive", "");
  if (!(max_yaw_deg >= 0 && max_yaw_deg <= 90 && max_pitch_deg >= 0 && max_pitch_deg <= 60))
    throw InvalidInput("--max-yaw", "yaw must lie in [0, 90] and pitch in [0, 60] degrees", "");
  if (!(noise >= 0 && noise <= 0.2)) throw InvalidInput("--noise", "must lie in [0, 0.2]", "");
}

std::vector<Camera> capture_cameras(const CaptureOptions& o, const Eigen::Vector3d& target) {
  o.check();
  const int rows = o.photos >= 12 ? 3 : 1;
  const double focal = o.size * o.distance / o.field_mm, deg = M_PI / 180;
  std::vector<Camera> cameras;
  for (int row = 0; row < rows; ++row) {
    const int n = o.photos / rows + (row < o.photos % rows);
    const double pitch = rows == 1 ? 0 : o.max_pitch_deg * (2.0 * row / (rows - 1) - 1);
    for (int k = 0; k < n; ++k) {
      // Rows staggered by a fraction of a step so that their cameras interleave in yaw.
      const double s = (k + (row + 0.5) / rows) / n;  // in (0, 1)
      const double yaw = o.max_yaw_deg * (2 * s - 1);
      const Eigen::Vector3d dir(std::sin(yaw * deg) * std::cos(pitch * deg), std::sin(pitch * deg),
                                std::cos(yaw * deg) * std::cos(pitch * deg));
      cameras.push_back(look_at_camera(target + o.distance * dir, target, o.size, o.size, focal));
    }
  }
  return cameras;
}

float backdrop_albedo(const Eigen::Vector3d& x, uint64_t seed) {
  // Large dots over medium over small ones (cells of 120, 45 and 16 mm): corners and blobs at every scale.
  for (const auto& [cell, density] : {std::pair{120.0, 0.8}, std::pair{45.0, 0.7}, std::pair{16.0, 0.6}}) {
    const double g = dots(x, cell, density, seed ^ uint64_t(cell));
    if (g >= 0) return float(0.04 + 0.7 * g);
  }
  return 0.25f;
}

Image render_capture_photo(const Mesh& scan, const Image* diffuse, const Camera& camera, const Eigen::Vector3d& target,
                           const CaptureOptions& o, int index) {
  o.check();
  const int ss = o.supersample;
  Camera big = camera;
  big.width *= ss, big.height *= ss, big.focal *= ss, big.cx *= ss, big.cy *= ss;
  ShadeOptions shade;
  shade.texture = diffuse;
  shade.gamma = default_lighting();
  const Frame frame = render_frame(scan, big, shade);
  // The backdrop: a sphere around the face's centre, 2.5 times the camera distance in radius (the rig's room).
  const Eigen::Vector3d eye = -camera.R.transpose() * camera.t;
  const double radius = 2.5 * o.distance;
  Image out(camera.width, camera.height, 3, ColorSpace::Linear);
  parallel_for(0, int64_t(camera.height), [&](int64_t y0, int64_t y1) {
    for (int y = int(y0); y < int(y1); ++y)
      for (int x = 0; x < camera.width; ++x) {
        Eigen::Vector3f sum = Eigen::Vector3f::Zero();
        for (int sy = 0; sy < ss; ++sy)
          for (int sx = 0; sx < ss; ++sx) {
            const int X = x * ss + sx, Y = y * ss + sy;
            const float m = frame.mask.at(X, Y);
            Eigen::Vector3f c(frame.colour.at(X, Y, 0), frame.colour.at(X, Y, 1), frame.colour.at(X, Y, 2));
            if (m < 1 && o.backdrop) {
              const Eigen::Vector3d d = (big.R.transpose() * Eigen::Vector3d((X + 0.5 - big.cx) / big.focal,
                                                                            -(Y + 0.5 - big.cy) / big.focal, -1))
                                            .normalized();
              const Eigen::Vector3d f = eye - target;  // |f + s d| = radius, the far root
              const double b = f.dot(d), s = -b + std::sqrt(std::max(0.0, b * b - f.squaredNorm() + radius * radius));
              c = Eigen::Vector3f::Constant(backdrop_albedo(eye + s * d, o.seed));
            }
            sum += c;
          }
        for (int ch = 0; ch < 3; ++ch) out.at(x, y, ch) = sum[ch] / float(ss * ss);
      }
  }, 16);
  if (o.noise > 0) {
    std::mt19937_64 rng(mix(o.seed ^ mix(uint64_t(index) + 77)));
    std::normal_distribution<float> n(0.f, float(o.noise));
    for (float& v : out.pixels) v = std::max(0.f, v + n(rng));
  }
  return to_srgb(out);
}

void write_capture_folder(const std::string& dir, const std::string& stem, const std::vector<Image>& pictures,
                          const std::vector<Camera>& cameras) {
  std::filesystem::create_directories(dir);
  nlohmann::json cams = nlohmann::json::array();
  for (size_t v = 0; v < pictures.size(); ++v) {
    char name[64];
    std::snprintf(name, sizeof name, "%s_%02zu.png", stem.c_str(), v);
    write_image(dir + "/" + name, pictures[v]);
    const Camera& c = cameras[v];
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) R.push_back({c.R(r, 0), c.R(r, 1), c.R(r, 2)});
    cams.push_back({{"image", name}, {"width", c.width}, {"height", c.height}, {"focal", c.focal}, {"cx", c.cx},
                    {"cy", c.cy}, {"R", R}, {"t", {c.t.x(), c.t.y(), c.t.z()}}});
  }
  write_file_atomic(dir + "/cameras.json", nlohmann::json{{"convention", "bareskin pinhole: p = R x + t, looks down -z"},
                                                          {"cameras", cams}}.dump(1) + "\n");
}

void write_synthetic_capture(const Mesh& mesh, const Image* diffuse, const std::string& dir, const CaptureOptions& o) {
  const Eigen::Vector3d target = (mesh.V.colwise().minCoeff() + mesh.V.colwise().maxCoeff()).transpose() / 2;
  const std::vector<Camera> cameras = capture_cameras(o, target);
  std::vector<Image> photos;
  const auto start = std::chrono::steady_clock::now();
  for (size_t k = 0; k < cameras.size(); ++k)
    photos.push_back(render_capture_photo(mesh, diffuse, cameras[k], target, o, int(k)));
  write_capture_folder(dir, "photo", photos, cameras);
  spdlog::info("landmarks capture: {} photos of {}² px ({}x supersampled{}) in {:.1f} s -> {}", photos.size(), o.size,
               o.supersample, o.backdrop ? ", speckle backdrop" : "",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), dir);
}

void write_synthetic_capture(const std::string& scan, const std::string& texture, const std::string& dir,
                             const CaptureOptions& options) {
  options.check();
  check_output_apart(dir, {scan, texture});
  const TexturedScan textured = read_textured_scan(scan, texture);
  write_synthetic_capture(textured.mesh, textured.diffuse ? &*textured.diffuse : nullptr, dir, options);
}

}  // namespace bareskin
