#include "render/rasterize.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/parallel.h"

namespace bareskin {
namespace {

constexpr int kTile = 32;

using raster::Setup;

// Writes pixel (px, py) when triangle `id` covers it and is nearer (ties: the lower id). Shared by both CPU
// rasterizers; the arithmetic is raster::sample, as in the CUDA rasterizer.
inline void shade_pixel(const Setup& s, int32_t id, int px, int py, bool orthographic, RasterOutput& out) {
  float d, b1, b2;
  if (!raster::sample(s, px, py, orthographic, d, b1, b2)) return;
  const size_t i = size_t(py) * size_t(out.width) + size_t(px);
  if (d > out.depth[i] || (d == out.depth[i] && out.triangle[i] >= 0 && out.triangle[i] < id)) return;
  out.depth[i] = d;
  out.triangle[i] = id;
  out.bary[2 * i] = b1;
  out.bary[2 * i + 1] = b2;
}

void check(const RasterInput& in) {
  if (in.width <= 0 || in.height <= 0 || int64_t(in.width) * in.height > (int64_t(1) << 28)) {
    throw InvalidInput("", "raster size " + std::to_string(in.width) + "x" + std::to_string(in.height) + " is out of range",
                       "use 1 to 16384 pixels a side");
  }
  for (int64_t i = 0; i < 3 * in.vertex_count; ++i) {
    if (!std::isfinite(in.xyw[i])) throw InvalidInput("", "a projected vertex is NaN or infinite", "check the mesh and camera");
  }
  for (int64_t i = 0; i < 3 * in.triangle_count; ++i) {
    if (in.triangles[i] < 0 || in.triangles[i] >= in.vertex_count) {
      throw InvalidInput("", "a triangle index is out of range", "check the mesh");
    }
  }
}

RasterOutput blank(const RasterInput& in) {
  RasterOutput out;
  out.width = in.width;
  out.height = in.height;
  const size_t n = size_t(in.width) * size_t(in.height);
  out.triangle.assign(n, -1);
  out.bary.assign(2 * n, 0.f);
  out.depth.assign(n, std::numeric_limits<float>::infinity());
  return out;
}

}  // namespace

RasterOutput rasterize(const RasterInput& in) {
  check(in);
  RasterOutput out = blank(in);
  const int tiles_x = (in.width + kTile - 1) / kTile, tiles_y = (in.height + kTile - 1) / kTile;
  std::vector<Setup> setups(static_cast<size_t>(in.triangle_count));
  std::vector<uint8_t> live(static_cast<size_t>(in.triangle_count), 0);
  std::vector<uint8_t> behind(static_cast<size_t>(in.triangle_count), 0);
  parallel_for(0, in.triangle_count, [&](int64_t b, int64_t e) {
    for (int64_t f = b; f < e; ++f) {
      const raster::SetupResult r = raster::setup(in, in.xyw, in.z, f, setups[size_t(f)]);
      live[size_t(f)] = r == raster::kLive;
      behind[size_t(f)] = r == raster::kBehind;
    }
  }, 4096);
  out.dropped_behind = std::count(behind.begin(), behind.end(), uint8_t(1));
  // Bin in id order, so every tile sees its triangles in the same order whatever the threads.
  std::vector<std::vector<int32_t>> bins(size_t(tiles_x) * size_t(tiles_y));
  for (int64_t f = 0; f < in.triangle_count; ++f) {
    if (!live[size_t(f)]) continue;
    const Setup& s = setups[size_t(f)];
    for (int ty = s.y0 / kTile; ty <= s.y1 / kTile; ++ty)
      for (int tx = s.x0 / kTile; tx <= s.x1 / kTile; ++tx) bins[size_t(ty) * size_t(tiles_x) + size_t(tx)].push_back(int32_t(f));
  }
  const bool orthographic = in.z != nullptr;
  parallel_for(0, int64_t(bins.size()), [&](int64_t b, int64_t e) {
    for (int64_t t = b; t < e; ++t) {
      const int tx = int(t % tiles_x), ty = int(t / tiles_x);
      const int px0 = tx * kTile, py0 = ty * kTile;
      const int px1 = std::min(in.width, px0 + kTile) - 1, py1 = std::min(in.height, py0 + kTile) - 1;
      for (int32_t f : bins[size_t(t)]) {
        const Setup& s = setups[size_t(f)];
        for (int py = std::max(py0, s.y0); py <= std::min(py1, s.y1); ++py)
          for (int px = std::max(px0, s.x0); px <= std::min(px1, s.x1); ++px) shade_pixel(s, f, px, py, orthographic, out);
      }
    }
  }, 1);
  return out;
}

RasterOutput rasterize_reference(const RasterInput& in) {
  check(in);
  RasterOutput out = blank(in);
  for (int64_t f = 0; f < in.triangle_count; ++f) {
    Setup s;
    const raster::SetupResult r = raster::setup(in, in.xyw, in.z, f, s);
    if (r != raster::kLive) {
      out.dropped_behind += r == raster::kBehind;
      continue;
    }
    for (int py = s.y0; py <= s.y1; ++py)
      for (int px = s.x0; px <= s.x1; ++px) shade_pixel(s, int32_t(f), px, py, in.z != nullptr, out);
  }
  return out;
}

std::vector<float> project_vertices(const Eigen::MatrixX3d& V, const Camera& camera, std::vector<float>& z) {
  const bool weak = camera.model == Camera::Model::WeakPerspective;
  std::vector<float> xyw(size_t(V.rows()) * 3);
  z.assign(weak ? size_t(V.rows()) : 0, 0.f);
  for (Eigen::Index i = 0; i < V.rows(); ++i) {
    const Eigen::Vector3d p = camera.project(V.row(i).transpose());
    xyw[3 * size_t(i)] = float(p.x());
    xyw[3 * size_t(i) + 1] = float(p.y());
    xyw[3 * size_t(i) + 2] = weak ? 1.f : float(p.z());
    if (weak) z[size_t(i)] = float(p.z());
  }
  return xyw;
}

RasterOutput rasterize_mesh(const Mesh& mesh, const Camera& camera, bool cull_back_faces) {
  std::vector<float> z;
  const std::vector<float> xyw = project_vertices(mesh.V, camera, z);
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> F = mesh.F;
  RasterInput in;
  in.xyw = xyw.data();
  in.z = z.empty() ? nullptr : z.data();
  in.triangles = F.data();
  in.vertex_count = mesh.V.rows();
  in.triangle_count = mesh.F.rows();
  in.width = camera.width;
  in.height = camera.height;
  in.cull_back_faces = cull_back_faces;
  return rasterize(in);
}

RasterOutput rasterize_uv(const Mesh& mesh, int size) {
  if (!mesh.has_uv()) throw InvalidInput("", "the mesh has no UVs to rasterise", "give a mesh with UVs");
  std::vector<float> xyw(size_t(mesh.UV.rows()) * 3), z(size_t(mesh.UV.rows()), 0.f);
  for (Eigen::Index i = 0; i < mesh.UV.rows(); ++i) {
    xyw[3 * size_t(i)] = float(mesh.UV(i, 0) * size);
    xyw[3 * size_t(i) + 1] = float((1 - mesh.UV(i, 1)) * size);
    xyw[3 * size_t(i) + 2] = 1.f;
  }
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> tri = mesh.FUV;
  RasterInput in;
  in.xyw = xyw.data();
  in.z = z.data();
  in.triangles = tri.data();
  in.vertex_count = mesh.UV.rows();
  in.triangle_count = mesh.FUV.rows();
  in.width = in.height = size;
  return rasterize(in);
}

const RasterOutput& given_or_own_uv(const RasterOutput* given, const Mesh& mesh, int size, RasterOutput& own) {
  if (!given) return own = rasterize_uv(mesh, size);
  BS_CHECK(given->width == size && given->height == size, "the given UV raster is not of the UV size");
  return *given;
}

std::vector<float> interpolate(const RasterOutput& r, const int32_t* triangles, const float* attribute, int channels) {
  std::vector<float> out(r.triangle.size() * size_t(channels), 0.f);
  parallel_for(0, int64_t(r.triangle.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const int32_t f = r.triangle[size_t(i)];
      if (f < 0) continue;
      const float w[3] = {1 - r.bary[2 * size_t(i)] - r.bary[2 * size_t(i) + 1], r.bary[2 * size_t(i)], r.bary[2 * size_t(i) + 1]};
      for (int k = 0; k < 3; ++k) {
        const float* a = attribute + size_t(triangles[3 * f + k]) * size_t(channels);
        for (int c = 0; c < channels; ++c) out[size_t(i) * size_t(channels) + size_t(c)] += w[k] * a[c];
      }
    }
  }, 4096);
  return out;
}

}  // namespace bareskin
