#include "scan/texture_refine.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "core/error.h"
#include "core/parallel.h"
#include "core/stats.h"
#include "scan/transfer.h"

namespace bareskin {
namespace {

Plane zeros(int n) { return Plane{n, std::vector<float>(size_t(n) * size_t(n), 0.f)}; }

// Separable Gaussian blur, clamped at the border. Each pass adds the kernel's taps in order, a whole row at a time
// (Eigen's vectorised row operations; the same sums in the same order as tap by tap per texel).
Plane blur(const Plane& in, double sigma) {
  if (sigma <= 0) return in;
  const int n = in.size, r = std::max(1, int(std::ceil(3 * sigma)));
  std::vector<float> k(size_t(2 * r + 1));
  float sum = 0;
  for (int i = -r; i <= r; ++i) sum += k[size_t(i + r)] = float(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& w : k) w /= sum;
  Plane tmp = zeros(n), out = zeros(n);
  parallel_for(0, n, [&](int64_t b, int64_t e) {
    std::vector<float> padded(size_t(n + 2 * r));
    for (int y = int(b); y < int(e); ++y) {
      for (int x = -r; x < n + r; ++x) padded[size_t(x + r)] = in.at(std::clamp(x, 0, n - 1), y);
      Eigen::Map<Eigen::ArrayXf> row(&tmp.at(0, y), n);
      for (int i = 0; i <= 2 * r; ++i) row += k[size_t(i)] * Eigen::Map<const Eigen::ArrayXf>(&padded[size_t(i)], n);
    }
  }, 16);
  parallel_for(0, n, [&](int64_t b, int64_t e) {
    for (int y = int(b); y < int(e); ++y) {
      Eigen::Map<Eigen::ArrayXf> row(&out.at(0, y), n);
      for (int i = -r; i <= r; ++i) {
        row += k[size_t(i + r)] * Eigen::Map<const Eigen::ArrayXf>(&tmp.at(0, std::clamp(y + i, 0, n - 1)), n);
      }
    }
  }, 16);
  return out;
}

// Normalised convolution: the Gaussian-weighted mean of `v` over texels weighted by `w` (0 where no weight is near).
Plane weighted_blur(const Plane& v, const Plane& w, double sigma) {
  Plane vw = v;
  for (size_t i = 0; i < vw.v.size(); ++i) vw.v[i] *= w.v[i];
  const Plane num = blur(vw, sigma), den = blur(w, sigma);
  Plane out = zeros(v.size);
  for (size_t i = 0; i < out.v.size(); ++i) out.v[i] = den.v[i] > 1e-6f ? num.v[i] / den.v[i] : 0.f;
  return out;
}

float bilinear(const Plane& p, float x, float y) {  // x, y in texel units, centres at integers
  const int n = p.size;
  x = std::clamp(x, 0.f, float(n - 1)), y = std::clamp(y, 0.f, float(n - 1));
  const int x0 = std::min(int(x), n - 2), y0 = std::min(int(y), n - 2);
  const float fx = x - float(x0), fy = y - float(y0);
  return (1 - fy) * ((1 - fx) * p.at(x0, y0) + fx * p.at(x0 + 1, y0)) + fy * ((1 - fx) * p.at(x0, y0 + 1) + fx * p.at(x0 + 1, y0 + 1));
}

// Half size: weighted 2x2 means of `v`, and the mean weight.
void downsample(const Plane& v, const Plane& w, Plane& v_out, Plane& w_out) {
  const int n = v.size / 2;
  v_out = zeros(n), w_out = zeros(n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      float sv = 0, sw = 0;
      for (int j = 0; j < 2; ++j)
        for (int i = 0; i < 2; ++i) sv += v.at(2 * x + i, 2 * y + j) * w.at(2 * x + i, 2 * y + j), sw += w.at(2 * x + i, 2 * y + j);
      v_out.at(x, y) = sw > 0 ? sv / sw : 0.f;
      w_out.at(x, y) = sw / 4;
    }
}

// Double size (bilinear), values scaled by `scale` (a displacement in texels doubles).
Plane upsample(const Plane& p, float scale) {
  const int n = 2 * p.size;
  Plane out = zeros(n);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) out.at(x, y) = scale * bilinear(p, (x + 0.5f) / 2 - 0.5f, (y + 0.5f) / 2 - 0.5f);
  return out;
}

// One pyramid level of Lucas-Kanade: `iterations` warps of `moving` by d, each solving the windowed 2x2 system for
// an update, then the confidence-weighted smoothing of d. Returns the confidence (smaller eigenvalue against its median).
Plane lucas_kanade(const Plane& moving, const Plane& fixed, const Plane& mask, Plane& dx, Plane& dy, double window,
                   double smoothing, double level_quantile, int iterations) {
  const int n = fixed.size;
  Plane confidence = zeros(n);
  for (int it = 0; it < iterations; ++it) {
    Plane warped = zeros(n), w = zeros(n);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const float sx = float(x) + dx.at(x, y), sy = float(y) + dy.at(x, y);
        if (mask.at(x, y) < 0.5f || sx < 0 || sy < 0 || sx > float(n - 1) || sy > float(n - 1)) continue;
        if (bilinear(mask, sx, sy) < 0.99f) continue;
        warped.at(x, y) = bilinear(moving, sx, sy);
        w.at(x, y) = 1;
      }
    Plane xx = zeros(n), xy = zeros(n), yy = zeros(n), xt = zeros(n), yt = zeros(n);
    for (int y = 1; y < n - 1; ++y)
      for (int x = 1; x < n - 1; ++x) {
        if (w.at(x, y) <= 0 || w.at(x - 1, y) <= 0 || w.at(x + 1, y) <= 0 || w.at(x, y - 1) <= 0 || w.at(x, y + 1) <= 0) continue;
        // Gradient: the fixed image's central differences.
        const float gx = 0.5f * (fixed.at(x + 1, y) - fixed.at(x - 1, y));
        const float gy = 0.5f * (fixed.at(x, y + 1) - fixed.at(x, y - 1));
        const float gt = warped.at(x, y) - fixed.at(x, y);
        xx.at(x, y) = gx * gx, xy.at(x, y) = gx * gy, yy.at(x, y) = gy * gy, xt.at(x, y) = gx * gt, yt.at(x, y) = gy * gt;
      }
    xx = blur(xx, window), xy = blur(xy, window), yy = blur(yy, window), xt = blur(xt, window), yt = blur(yt, window);
    std::vector<double> lambdas;
    Plane lambda = zeros(n);
    for (size_t i = 0; i < lambda.v.size(); ++i) {
      const double a = xx.v[i], b = xy.v[i], c = yy.v[i];
      lambda.v[i] = float(std::max(0.0, 0.5 * (a + c) - std::sqrt(0.25 * (a - c) * (a - c) + b * b)));
      if (mask.v[i] >= 0.5f) lambdas.push_back(lambda.v[i]);
    }
    const double kappa = std::max(1e-8, lambdas.empty() ? 1.0 : quantile(lambdas, level_quantile));
    for (size_t i = 0; i < lambda.v.size(); ++i) {
      if (mask.v[i] < 0.5f) continue;
      const double a = xx.v[i] + 0.1 * kappa, b = xy.v[i], c = yy.v[i] + 0.1 * kappa, det = a * c - b * b;
      double ux = -(c * xt.v[i] - b * yt.v[i]) / det, uy = -(a * yt.v[i] - b * xt.v[i]) / det;
      const double len = std::hypot(ux, uy);
      if (len > 1) ux /= len, uy /= len;  // at most a texel per iteration and level
      dx.v[i] += float(ux), dy.v[i] += float(uy);
      confidence.v[i] = float(lambda.v[i] / (lambda.v[i] + kappa)) * mask.v[i];
    }
    dx = weighted_blur(dx, confidence, smoothing), dy = weighted_blur(dy, confidence, smoothing);
  }
  return confidence;
}

// The template triangle whose UV holds `uv` (the raster's texel under it, then its neighbours) and its barycentrics
// there; -1 when none does.
int template_triangle_at_uv(const Mesh& mesh, const RasterOutput& raster, const Eigen::Vector2d& uv, Eigen::Vector3d& w) {
  const int size = raster.width;
  const int cx = int(std::floor(uv.x() * size)), cy = int(std::floor((1 - uv.y()) * size));
  for (int r = 0; r <= 1; ++r)
    for (int y = cy - r; y <= cy + r; ++y)
      for (int x = cx - r; x <= cx + r; ++x) {
        if (x < 0 || y < 0 || x >= size || y >= size) continue;
        const int f = raster.triangle[size_t(y) * size_t(size) + size_t(x)];
        if (f < 0) continue;
        const Eigen::Vector2d a = mesh.UV.row(mesh.FUV(f, 0)), e0 = Eigen::Vector2d(mesh.UV.row(mesh.FUV(f, 1))) - a,
                              e1 = Eigen::Vector2d(mesh.UV.row(mesh.FUV(f, 2))) - a, q = uv - a;
        const double det = e0.x() * e1.y() - e0.y() * e1.x();
        if (!(std::abs(det) > 1e-18)) continue;
        const double l1 = (q.x() * e1.y() - q.y() * e1.x()) / det, l2 = (e0.x() * q.y() - e0.y() * q.x()) / det;
        w = Eigen::Vector3d(1 - l1 - l2, l1, l2).cwiseMax(0.0);
        if (!(w.sum() > 0)) continue;
        w /= w.sum();
        return f;
      }
  return -1;
}

}  // namespace

void TextureRefineOptions::check() const {
  if (iterations < 0 || iterations > 10) throw InvalidInput("", "--texture-refine must lie in [0, 10] rounds", "");
  if (resolution < 64 || resolution > 2048 || (resolution & (resolution - 1)) != 0) {
    throw InvalidInput("", "--texture-res must be a power of two in [64, 2048]", "use 256");
  }
  if (landmark_rounds < 0 || landmark_rounds > 5) throw InvalidInput("", "--texture-landmarks must lie in [0, 5] rounds", "");
  if (shape_points < 0 || shape_points > 100000) throw InvalidInput("", "--shape-points must lie in [0, 100000]", "");
  if (!(shape_point_weight >= 0 && shape_point_weight <= 100)) {
    throw InvalidInput("", "--shape-point-weight must lie in [0, 100]", "0.01 is the measured best");
  }
  if (landmark_resolution < 128 || landmark_resolution > 2048 || (landmark_resolution & (landmark_resolution - 1)) != 0) {
    throw InvalidInput("", "--texture-landmark-res must be a power of two in [128, 2048]", "use 512");
  }
  if (!(landmark_structure_sigma > 0) || !(landmark_window > 0) || !(landmark_smoothing > 0)) {
    throw InvalidInput("", "texture landmarks' flow sizes must be > 0", "");
  }
  if (levels < 1 || (resolution >> (levels - 1)) < 16) {
    throw InvalidInput("", "the texture flow needs 1 or more pyramid levels, the coarsest at least 16 texels", "");
  }
  if (nicp_iterations < 1 || !(weight > 0) || !(data_weight > 0) || !(stiffness > 0) || !(max_move_mm > 0) ||
      !(min_confidence >= 0 && min_confidence < 1) || !(confidence_quantile > 0 && confidence_quantile < 1) || !(window > 0) || !(smoothing > 0) || !(structure_sigma > 0)) {
    throw InvalidInput("", "texture refinement weights and sizes must be > 0 and its iterations >= 1", "");
  }
}

Image transfer_diffuse(const RasterOutput& raster, const Mesh& template_mesh, const Eigen::MatrixX3d& V,
                       const Mesh& scan, const SurfaceLocator& scan_locator, const Image& scan_diffuse,
                       std::vector<uint8_t>& valid) {
  if (!scan.has_uv()) throw InvalidInput("scan", "has no UV atlas, so its diffuse cannot be read", "give a scan with UVs");
  BS_CHECK(raster.width == raster.height && V.rows() == template_mesh.V.rows(), "transfer_diffuse: raster or V mismatch");
  const int n = raster.width;
  Image out(n, n, 3, ColorSpace::Linear, 0.f);
  valid.assign(size_t(n) * size_t(n), 0);
  const Eigen::MatrixX3i& F = template_mesh.F;  // rasterize_uv's triangle ids are rows of F (and FUV)
  parallel_for(0, int64_t(n) * n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const int32_t f = raster.triangle[size_t(i)];
      if (f < 0) continue;
      const double b1 = raster.bary[2 * size_t(i)], b2 = raster.bary[2 * size_t(i) + 1];
      const ScanAtlasPoint a = scan_atlas_point(V, F, f, Eigen::Vector3d(1 - b1 - b2, b1, b2), scan, scan_locator);
      if (!a.ok) continue;
      const Eigen::Vector2d& uv = a.uv;
      const Eigen::Vector3f c = sample_bilinear(scan_diffuse, uv);
      for (int k = 0; k < 3; ++k) out.pixels[size_t(i) * 3 + size_t(k)] = c[k];
      valid[size_t(i)] = c.sum() > 1e-4f;  // 0: outside the scan's charts
    }
  }, 4096);
  return out;
}

std::vector<uint8_t> layout_mask(const RasterOutput& raster) {
  std::vector<uint8_t> mask(raster.triangle.size(), 0);
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = raster.triangle[i] >= 0;
  return mask;
}

Image resample_square(const Image& image, int size) {
  const Image in = image.color_space == ColorSpace::sRGB ? to_linear(image) : image;
  Image out(size, size, 3, ColorSpace::Linear, 0.f);
  const bool box = in.width == in.height && in.width % size == 0;
  const int f = box ? in.width / size : 1;
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      Eigen::Vector3f c = Eigen::Vector3f::Zero();
      if (box) {
        for (int j = 0; j < f; ++j)
          for (int i = 0; i < f; ++i)
            for (int k = 0; k < 3; ++k) c[k] += in.at(x * f + i, y * f + j, std::min(k, in.channels - 1));
        c /= float(f * f);
      } else {
        c = sample_bilinear(in, Eigen::Vector2d((x + 0.5) / size, 1 - (y + 0.5) / size));
      }
      for (int k = 0; k < 3; ++k) out.at(x, y, k) = c[k];
    }
  return out;
}

Plane texture_structure(const Image& linear, const std::vector<uint8_t>& valid, double sigma, double floor,
                        TextureChannel channel) {
  BS_CHECK(linear.width == linear.height && linear.channels >= 3, "texture_structure needs a square RGB image");
  const int n = linear.width;
  Plane log_lum = zeros(n), mask = zeros(n);
  for (size_t i = 0; i < log_lum.v.size(); ++i) {
    const float r = linear.pixels[i * 3], g = linear.pixels[i * 3 + 1], b = linear.pixels[i * 3 + 2];
    if (!valid[i] || !(r + g + b > 0)) continue;
    mask.v[i] = 1;
    log_lum.v[i] = channel == TextureChannel::Luminance ? std::log(0.2126f * r + 0.7152f * g + 0.0722f * b + 0.01f)
                                                        : std::log((r + 0.01f) / (g + 0.01f));
  }
  return plane_structure(log_lum, mask, sigma, floor);
}

Plane plane_structure(const Plane& values, const Plane& mask, double sigma, double floor) {
  // A texel's worth of smoothing (pores and sensor noise are not what the flow should follow), then the local mean
  // and deviation; the deviation has a floor so that plain skin stays flat instead of amplified noise.
  const int n = values.size;
  const Plane smooth = weighted_blur(values, mask, 1.0 * n / 256), mean = weighted_blur(smooth, mask, sigma);
  Plane sq = zeros(n);
  for (size_t i = 0; i < sq.v.size(); ++i) sq.v[i] = (smooth.v[i] - mean.v[i]) * (smooth.v[i] - mean.v[i]);
  const Plane var = weighted_blur(sq, mask, sigma);
  Plane out = zeros(n);
  for (size_t i = 0; i < out.v.size(); ++i)
    if (mask.v[i] > 0) out.v[i] = (smooth.v[i] - mean.v[i]) / std::sqrt(var.v[i] + float(floor * floor));
  return out;
}

Eigen::Vector2f UvFlow::at(const Eigen::Vector2d& uv, float* confidence_out) const {
  const int n = dx.size;
  const float x = float(uv.x() * n - 0.5), y = float((1 - uv.y()) * n - 0.5);
  if (confidence_out) *confidence_out = bilinear(confidence, x, y);
  return {bilinear(dx, x, y), bilinear(dy, x, y)};
}

UvFlow uv_flow(const Plane& moving, const Plane& fixed, const std::vector<uint8_t>& mask, const TextureRefineOptions& o) {
  BS_CHECK(moving.size == fixed.size && mask.size() == fixed.v.size(), "uv_flow: sizes differ");
  std::vector<Plane> mv(size_t(o.levels)), fx(size_t(o.levels)), w(size_t(o.levels));
  mv[0] = moving, fx[0] = fixed, w[0] = zeros(fixed.size);
  for (size_t i = 0; i < mask.size(); ++i) w[0].v[i] = mask[i] ? 1.f : 0.f;
  for (size_t l = 1; l < size_t(o.levels); ++l) {
    Plane unused;
    downsample(mv[l - 1], w[l - 1], mv[l], w[l]);
    downsample(fx[l - 1], w[l - 1], fx[l], unused);
  }
  for (size_t l = 0; l < size_t(o.levels); ++l)  // a coarse texel is in when most of its texels are
    for (float& v : w[l].v) v = v >= 0.75f ? 1.f : 0.f;
  Plane dx = zeros(mv.back().size), dy = dx;
  UvFlow out;
  for (int l = o.levels - 1; l >= 0; --l) {
    if (dx.size != mv[size_t(l)].size) dx = upsample(dx, 2), dy = upsample(dy, 2);
    out.confidence = lucas_kanade(mv[size_t(l)], fx[size_t(l)], w[size_t(l)], dx, dy, o.window, o.smoothing, o.confidence_quantile, 3);
  }
  out.dx = dx, out.dy = dy;
  out.confidence = blur(out.confidence, o.window);
  return out;
}

std::vector<int> vertex_uv_rows(const Mesh& mesh) {
  std::vector<int> rows(size_t(mesh.V.rows()), -1);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) rows[size_t(mesh.F(f, k))] = mesh.FUV(f, k);
  return rows;
}

bool flow_target(const Mesh& mesh, const Eigen::MatrixX3d& V, const RasterOutput& raster, const UvFlow& flow,
                 const SurfaceLocator& scan_locator, const std::vector<int>& uv_rows, int v,
                 const TextureRefineOptions& o, FlowTarget& out) {
  if (uv_rows[size_t(v)] < 0) return false;
  const Eigen::Vector2d uv = mesh.UV.row(uv_rows[size_t(v)]);
  float c = 0;
  const Eigen::Vector2f d = flow.at(uv, &c);
  if (!(c >= o.min_confidence) || !d.allFinite()) return false;
  Eigen::Vector3d w;
  const int f = template_triangle_at_uv(mesh, raster, uv + Eigen::Vector2d(d.x(), -d.y()) / double(raster.width), w);
  if (f < 0) return false;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) p += w[k] * V.row(mesh.F(f, k)).transpose();
  out.point = scan_locator.locate(p).point;
  out.move_mm = (out.point - V.row(v).transpose()).norm();
  out.confidence = c;
  return out.move_mm <= o.max_move_mm;
}

TextureTargets texture_targets(const Mesh& mesh, const Eigen::MatrixX3d& V, const RasterOutput& raster,
                               const UvFlow& flow, const SurfaceLocator& scan_locator, const TextureRefineOptions& o) {
  const Eigen::Index n = mesh.V.rows();
  const std::vector<int> uv_rows = vertex_uv_rows(mesh);
  std::vector<FlowTarget> target(static_cast<size_t>(n));
  parallel_for(0, n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i)
      if (!flow_target(mesh, V, raster, flow, scan_locator, uv_rows, int(i), o, target[size_t(i)])) target[size_t(i)] = {};
  }, 1024);
  TextureTargets t;
  std::vector<double> kept;
  for (Eigen::Index i = 0; i < n; ++i) {
    const FlowTarget& f = target[size_t(i)];
    if (f.confidence <= 0) continue;
    t.vertex.push_back(int(i));
    t.point.push_back(f.point);
    t.confidence.push_back(f.confidence);
    kept.push_back(f.move_mm);
  }
  if (!kept.empty()) t.median_move_mm = quantile(kept, 0.5);
  return t;
}

}  // namespace bareskin
