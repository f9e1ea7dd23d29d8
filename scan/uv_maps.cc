#include "scan/uv_maps.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <future>
#include <limits>
#include <optional>
#include <vector>

#include "core/error.h"
#include "core/image_io.h"
#include "core/parallel.h"

namespace bareskin {
namespace {

float cross2(const Eigen::Vector2f& a, const Eigen::Vector2f& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

MapFormat parse_map_format(const std::string& name) {
  if (name == "png") return MapFormat::Png16;
  if (name == "tif" || name == "tiff") return MapFormat::Tiff16;
  if (name == "exr") return MapFormat::Exr;
  throw InvalidInput("--map-format", "unknown map format '" + name + "'", "use png, tif or exr");
}

const char* map_extension(MapFormat format) {
  switch (format) {
    case MapFormat::Png16: return ".png";
    case MapFormat::Tiff16: return ".tif";
    case MapFormat::Exr: return ".exr";
  }
  return ".png";
}

void BakeOptions::check() const {
  if (resolution < 16 || resolution > 32768) throw InvalidInput("--res", "must lie in [16, 32768]", "");
  if (gutter < 0 || gutter > 64) throw InvalidInput("--gutter", "must lie in [0, 64] texels", "");
  if (band_rows < 1) throw InternalError("BakeOptions: band_rows < 1");
}

void write_uv_maps(const Mesh& mesh, const BakeOptions& options, const std::string& dir,
                   const std::function<MapTexel(int face, const Eigen::Vector3f& barycentric, int x, int y)>& texel,
                   const ProgressCallback& progress, const MapSelection& which) {
  options.check();
  const Mesh& m = mesh;
  const int R = options.resolution, gutter = options.gutter;
  const bool exr = options.format == MapFormat::Exr;
  const std::string ext = map_extension(options.format);
  ImageWriteOptions io;
  io.type = exr ? PixelType::Half : PixelType::UInt16;
  std::optional<ImageStreamWriter> diffuse, normal, roughness, specular;
  if (which.diffuse) diffuse.emplace(dir + "/diffuse" + ext, R, R, 3, exr ? ColorSpace::Linear : ColorSpace::sRGB, io);
  if (which.normal) normal.emplace(dir + "/normal" + ext, R, R, 3, ColorSpace::Data, io);
  if (which.roughness) roughness.emplace(dir + "/roughness" + ext, R, R, 1, ColorSpace::Data, io);
  if (which.specular) specular.emplace(dir + "/specular" + ext, R, R, 1, ColorSpace::Data, io);

  // Triangles in texel coordinates (x right, y down from the top row), binned by band.
  const int bands = (R + options.band_rows - 1) / options.band_rows;
  std::vector<std::vector<int>> in_band(static_cast<size_t>(bands));
  std::vector<std::array<Eigen::Vector2f, 3>> corners(size_t(m.F.rows()));
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    float y0 = std::numeric_limits<float>::max(), y1 = -y0;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d uv = m.UV.row(m.FUV(f, k));
      corners[size_t(f)][size_t(k)] = Eigen::Vector2f(float(uv.x() * R), float((1 - uv.y()) * R));
      y0 = std::min(y0, corners[size_t(f)][size_t(k)].y());
      y1 = std::max(y1, corners[size_t(f)][size_t(k)].y());
    }
    const int b0 = std::max(0, int(std::floor(y0 - gutter - 1)) / options.band_rows);
    const int b1 = std::min(bands - 1, int(std::floor(y1 + gutter + 1)) / options.band_rows);
    for (int b = b0; b <= b1; ++b) in_band[size_t(b)].push_back(int(f));
  }

  // Two sets of band buffers: one band is written (compressed) on a helper thread while the next is evaluated.
  struct Band {
    std::vector<float> d, n, r, s;
  } bands_buf[2];
  std::future<void> writing;
  std::vector<float> dist;
  std::vector<int> tri;
  std::vector<Eigen::Vector3f> bary;
  for (int band = 0; band < bands; ++band) {
    const int yb = band * options.band_rows, ye = std::min(R, yb + options.band_rows), rows = ye - yb;
    const size_t texels = size_t(rows) * R;
    dist.assign(texels, std::numeric_limits<float>::max());
    tri.assign(texels, -1);
    bary.assign(texels, Eigen::Vector3f::Zero());
    // Rasterise: inside a triangle (distance 0) wins; else the nearest triangle within the gutter, at its closest point.
    const int chunks = std::max(1, std::min(rows, num_threads()));
    parallel_for(0, chunks, [&](int64_t c0, int64_t c1) {
      for (int64_t c = c0; c < c1; ++c) {
        const int r0 = yb + int(c * rows / chunks), r1 = yb + int((c + 1) * rows / chunks);
        for (int f : in_band[size_t(band)]) {
          const auto& q = corners[size_t(f)];
          const float area = cross2(q[1] - q[0], q[2] - q[0]);
          if (std::abs(area) < 1e-12f) continue;
          const float x_lo = std::min({q[0].x(), q[1].x(), q[2].x()}) - gutter, x_hi = std::max({q[0].x(), q[1].x(), q[2].x()}) + gutter;
          const float y_lo = std::min({q[0].y(), q[1].y(), q[2].y()}) - gutter, y_hi = std::max({q[0].y(), q[1].y(), q[2].y()}) + gutter;
          const int xa = std::max(0, int(std::floor(x_lo))), xb = std::min(R - 1, int(std::ceil(x_hi)));
          const int ya = std::max(r0, int(std::floor(y_lo))), yc = std::min(r1 - 1, int(std::ceil(y_hi)));
          for (int y = ya; y <= yc; ++y) {
            for (int x = xa; x <= xb; ++x) {
              const size_t i = size_t(y - yb) * R + x;
              if (dist[i] <= 0) continue;
              const Eigen::Vector2f p(float(x) + 0.5f, float(y) + 0.5f);
              const float s = cross2(p - q[0], q[2] - q[0]) / area, t = cross2(q[1] - q[0], p - q[0]) / area;
              if (s >= 0 && t >= 0 && s + t <= 1) {
                dist[i] = 0;
                tri[i] = f;
                bary[i] = Eigen::Vector3f(1 - s - t, s, t);
                continue;
              }
              if (gutter == 0) continue;
              for (int e = 0; e < 3; ++e) {
                const Eigen::Vector2f a = q[size_t(e)], ab = q[size_t((e + 1) % 3)] - a;
                const float u = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12f), 0.0f, 1.0f);
                const float d = (a + u * ab - p).norm();
                if (d <= float(gutter) && d < dist[i]) {
                  dist[i] = d;
                  tri[i] = f;
                  Eigen::Vector3f w = Eigen::Vector3f::Zero();
                  w[e] = 1 - u;
                  w[(e + 1) % 3] = u;
                  bary[i] = w;
                }
              }
            }
          }
        }
      }
    });
    // The value at every covered texel.
    std::vector<float>&d_buf = bands_buf[band % 2].d, &n_buf = bands_buf[band % 2].n, &r_buf = bands_buf[band % 2].r,
                      &s_buf = bands_buf[band % 2].s;
    d_buf.assign(texels * 3, 0.f);
    n_buf.assign(texels * 3, 0.f);
    r_buf.assign(texels, 0.f);
    s_buf.assign(texels, 0.f);
    for (size_t i = 0; i < texels; ++i) n_buf[3 * i + 2] = 1;  // flat normal where no chart is
    parallel_for(0, int64_t(texels), [&](int64_t i0, int64_t i1) {
      for (int64_t i = i0; i < i1; ++i) {
        const int f = tri[size_t(i)];
        if (f < 0) continue;
        const MapTexel value = texel(f, bary[size_t(i)], int(i % R), yb + int(i / R));
        for (int k = 0; k < 3; ++k) {
          const float c = std::max(0.0f, value.diffuse[k]);
          d_buf[size_t(3 * i + k)] = exr ? c : linear_to_srgb(c);
          n_buf[size_t(3 * i + k)] = value.normal[k];
        }
        r_buf[size_t(i)] = value.roughness;
        s_buf[size_t(i)] = value.specular;
      }
    }, 4096);
    for (float& v : n_buf) v = 0.5f * (v + 1);
    if (writing.valid()) writing.get();  // the previous band is on disk (rethrows its error)
    writing = std::async(std::launch::async, [&, yb, ye, band] {
      const Band& out = bands_buf[band % 2];
      if (diffuse) diffuse->write_rows(yb, ye, out.d.data());
      if (normal) normal->write_rows(yb, ye, out.n.data());
      if (roughness) roughness->write_rows(yb, ye, out.r.data());
      if (specular) specular->write_rows(yb, ye, out.s.data());
    });
    report(progress, band + 1, bands, "maps");
  }
  if (writing.valid()) writing.get();
  for (auto* w : {&diffuse, &normal, &roughness, &specular})
    if (*w) (*w)->commit();
}

}  // namespace bareskin
