#include "scan/texture_refine.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "core/stats.h"

namespace bareskin {
namespace {

using Plane = std::vector<float>;

// Separable Gaussian blur of an n x n plane, clamped at the border.
Plane blur(const Plane& in, int n, double sigma) {
  if (sigma <= 0) return in;
  const int r = std::max(1, int(std::ceil(3 * sigma)));
  std::vector<float> k(size_t(2 * r + 1));
  float sum = 0;
  for (int i = -r; i <= r; ++i) sum += k[size_t(i + r)] = float(std::exp(-0.5 * i * i / (sigma * sigma)));
  for (float& w : k) w /= sum;
  Plane tmp(in.size()), out(in.size());
  parallel_for(0, n, [&](int64_t b, int64_t e) {
    for (int64_t y = b; y < e; ++y)
      for (int x = 0; x < n; ++x) {
        float s = 0;
        for (int i = -r; i <= r; ++i) s += k[size_t(i + r)] * in[size_t(y) * size_t(n) + size_t(std::clamp(x + i, 0, n - 1))];
        tmp[size_t(y) * size_t(n) + size_t(x)] = s;
      }
  }, 16);
  parallel_for(0, n, [&](int64_t b, int64_t e) {
    for (int64_t y = b; y < e; ++y)
      for (int x = 0; x < n; ++x) {
        float s = 0;
        for (int i = -r; i <= r; ++i) s += k[size_t(i + r)] * tmp[size_t(std::clamp(int(y) + i, 0, n - 1)) * size_t(n) + size_t(x)];
        out[size_t(y) * size_t(n) + size_t(x)] = s;
      }
  }, 16);
  return out;
}

// Normalised convolution: the Gaussian-weighted mean of `v` over texels with weight `w` (0 where no weight is near).
Plane weighted_blur(const Plane& v, const Plane& w, int n, double sigma) {
  Plane vw(v.size());
  for (size_t i = 0; i < v.size(); ++i) vw[i] = v[i] * w[i];
  const Plane num = blur(vw, n, sigma), den = blur(w, n, sigma);
  Plane out(v.size());
  for (size_t i = 0; i < v.size(); ++i) out[i] = den[i] > 1e-6f ? num[i] / den[i] : 0.f;
  return out;
}

}  // namespace

void TextureRefineOptions::check() const {
  if (iterations < 0 || iterations > 10) throw InvalidInput("", "--texture-refine must lie in [0, 10] rounds", "");
  if (resolution < 64 || resolution > 4096 || (resolution & (resolution - 1)) != 0) {
    throw InvalidInput("", "--texture-res must be a power of two in [64, 4096]", "use 512");
  }
  if (nicp_iterations < 1 || !(weight > 0) || !(data_weight > 0) || !(stiffness > 0) || !(max_flow_mm > 0) || !(min_confidence >= 0)) {
    throw InvalidInput("", "texture refinement weights must be > 0 and its iterations >= 1", "");
  }
}

double mm_per_uv(const Mesh& m) {
  std::vector<double> r;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const double mm = (m.V.row(m.F(f, 1)) - m.V.row(m.F(f, 0))).norm();
    const double uv = (m.UV.row(m.FUV(f, 1)) - m.UV.row(m.FUV(f, 0))).norm();
    if (uv > 0) r.push_back(mm / uv);
  }
  return quantile(r, 0.5);
}

bool UvRaster::locate(const Eigen::Vector2d& uv, int& f, Eigen::Vector3d& bary) const {
  const int cx = int(std::floor(uv.x() * size)), cy = int(std::floor((1 - uv.y()) * size));
  double best = 1e9;
  f = -1;
  for (int r = 0; r <= 2 && f < 0; ++r)
    for (int y = cy - r; y <= cy + r; ++y)
      for (int x = cx - r; x <= cx + r; ++x) {
        if (x < 0 || y < 0 || x >= size || y >= size) continue;
        const int g = face[size_t(y) * size_t(size) + size_t(x)];
        if (g < 0) continue;
        const Eigen::Vector2d a = UV->row((*FUV)(g, 0)), b = UV->row((*FUV)(g, 1)), c = UV->row((*FUV)(g, 2));
        const Eigen::Vector2d e0 = b - a, e1 = c - a, q = uv - a;
        const double det = e0.x() * e1.y() - e0.y() * e1.x();
        if (std::abs(det) < 1e-18) continue;
        const double l1 = (q.x() * e1.y() - q.y() * e1.x()) / det, l2 = (e0.x() * q.y() - e0.y() * q.x()) / det;
        Eigen::Vector3d w(1 - l1 - l2, l1, l2);
        if (!w.allFinite()) continue;
        const double outside = -std::min(0.0, w.minCoeff());
        if (outside < best && w.cwiseMax(0.0).sum() > 0) {
          best = outside;
          w = w.cwiseMax(0.0);
          bary = w / w.sum();
          f = g;
        }
      }
  return f >= 0;
}

UvRaster uv_texel_raster(const Mesh& mesh, int size) {
  if (!mesh.has_uv()) throw InvalidInput("template", "has no UVs, so no texture refinement", "use a template with UVs");
  UvRaster r;
  r.size = size;
  r.face.assign(size_t(size) * size_t(size), -1);
  r.barycentric.assign(r.face.size(), Eigen::Vector3f::Zero());
  r.F = &mesh.F;
  r.UV = &mesh.UV;
  r.FUV = &mesh.FUV;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    Eigen::Vector2d p[3];  // texel coordinates, centres at integers + 0.5
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector2d uv = mesh.UV.row(mesh.FUV(f, k));
      p[k] = Eigen::Vector2d(uv.x() * size, (1 - uv.y()) * size);
    }
    const double det = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[1] - p[0]).y() * (p[2] - p[0]).x();
    if (std::abs(det) < 1e-12) continue;
    const int x0 = std::max(0, int(std::floor(std::min({p[0].x(), p[1].x(), p[2].x()})))),
              x1 = std::min(size - 1, int(std::ceil(std::max({p[0].x(), p[1].x(), p[2].x()})))),
              y0 = std::max(0, int(std::floor(std::min({p[0].y(), p[1].y(), p[2].y()})))),
              y1 = std::min(size - 1, int(std::ceil(std::max({p[0].y(), p[1].y(), p[2].y()}))));
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const Eigen::Vector2d q = Eigen::Vector2d(x + 0.5, y + 0.5) - p[0], e0 = p[1] - p[0], e1 = p[2] - p[0];
        const double l1 = (q.x() * e1.y() - q.y() * e1.x()) / det, l2 = (e0.x() * q.y() - e0.y() * q.x()) / det;
        if (l1 < -1e-9 || l2 < -1e-9 || l1 + l2 > 1 + 1e-9) continue;
        const size_t i = size_t(y) * size_t(size) + size_t(x);
        r.face[i] = int(f);
        r.barycentric[i] = Eigen::Vector3f(float(1 - l1 - l2), float(l1), float(l2));
      }
  }
  return r;
}

Image transfer_diffuse(const UvRaster& raster, const Eigen::MatrixX3d& V, const Mesh& scan, const SurfaceLocator& locator,
                       const Image& scan_diffuse, std::vector<uint8_t>& valid) {
  if (!scan.has_uv()) throw InvalidInput("scan", "has no UV atlas, so its diffuse cannot be read", "give a scan with UVs");
  const int n = raster.size;
  Image out(n, n, 3, ColorSpace::Linear, 0.f);
  valid.assign(size_t(n) * size_t(n), 0);
  const Eigen::MatrixX3i& F = *raster.F;
  parallel_for(0, int64_t(n) * n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const int f = raster.face[size_t(i)];
      if (f < 0) continue;
      const Eigen::Vector3f& w = raster.barycentric[size_t(i)];
      const Eigen::Vector3d p = double(w[0]) * V.row(F(f, 0)).transpose() + double(w[1]) * V.row(F(f, 1)).transpose() +
                                double(w[2]) * V.row(F(f, 2)).transpose();
      if (!p.allFinite()) continue;
      const SurfacePoint s = locator.locate(p);
      if (s.face < 0 || !s.barycentric.allFinite()) continue;
      Eigen::Vector2d uv = Eigen::Vector2d::Zero();
      for (int k = 0; k < 3; ++k) uv += s.barycentric[k] * scan.UV.row(scan.FUV(s.face, k)).transpose();
      const Eigen::Vector3f c = sample_bilinear(scan_diffuse, uv);
      for (int k = 0; k < 3; ++k) out.pixels[size_t(i) * 3 + size_t(k)] = c[k];
      valid[size_t(i)] = c.sum() > 1e-4f;  // 0: outside the scan's charts (a map without gutters)
    }
  }, 4096);
  return out;
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

TextureStructure normalise_texture(const Image& linear, const std::vector<uint8_t>& valid, double sigma) {
  BS_CHECK(linear.width == linear.height && linear.channels >= 3, "normalise_texture needs a square RGB image");
  const int n = linear.width;
  const size_t count = size_t(n) * size_t(n);
  TextureStructure s;
  s.size = n;
  s.mask.assign(count, 0.f);
  Plane raw[2] = {Plane(count, 0.f), Plane(count, 0.f)};
  constexpr float eps = 0.01f;
  for (size_t i = 0; i < count; ++i) {
    const float r = linear.pixels[i * 3], g = linear.pixels[i * 3 + 1], b = linear.pixels[i * 3 + 2];
    if (!valid[i] || r + g + b <= 0) continue;
    s.mask[i] = 1;
    raw[0][i] = std::log(0.2126f * r + 0.7152f * g + 0.0722f * b + eps);
    raw[1][i] = std::log(r + eps) - std::log(g + eps);
  }
  for (int c = 0; c < 2; ++c) {
    const Plane mean = weighted_blur(raw[c], s.mask, n, sigma);
    Plane high(count, 0.f);
    std::vector<double> magnitude;
    for (size_t i = 0; i < count; ++i) {
      if (s.mask[i] <= 0) continue;
      high[i] = raw[c][i] - mean[i];
      magnitude.push_back(std::abs(high[i]));
    }
    // Spread: the 90th percentile of |high-pass| (balances the two channels; the matching is contrast-invariant).
    const double spread = magnitude.empty() ? 1.0 : std::max(1e-4, quantile(magnitude, 0.9));
    for (float& v : high) v = float(v / spread);
    s.channel[c] = blur(high, n, 0.7);  // a little anti-aliasing of the transfer's point samples
  }
  return s;
}

Eigen::Vector2f UvFlow::at(const Eigen::Vector2d& uv, float* confidence_out) const {
  const float x = std::clamp(float(uv.x() * size - 0.5), 0.f, float(size - 1));
  const float y = std::clamp(float((1 - uv.y()) * size - 0.5), 0.f, float(size - 1));
  const int x0 = std::min(int(x), size - 2), y0 = std::min(int(y), size - 2);
  const float fx = x - float(x0), fy = y - float(y0);
  const size_t i00 = size_t(y0) * size_t(size) + size_t(x0), i01 = i00 + 1, i10 = i00 + size_t(size), i11 = i10 + 1;
  const float w00 = (1 - fx) * (1 - fy), w01 = fx * (1 - fy), w10 = (1 - fx) * fy, w11 = fx * fy;
  if (confidence_out) {
    *confidence_out = w00 * confidence[i00] + w01 * confidence[i01] + w10 * confidence[i10] + w11 * confidence[i11];
  }
  return Eigen::Vector2f(w00 * d[i00] + w01 * d[i01] + w10 * d[i10] + w11 * d[i11]);
}

UvFlow uv_flow(const TextureStructure& moving, const TextureStructure& fixed, int radius) {
  BS_CHECK(moving.size == fixed.size, "uv_flow needs images of one size");
  const int n = moving.size, h = std::max(3, n / 40), step = std::max(2, n / 96);
  const size_t count = size_t(n) * size_t(n);
  Plane mask(count);
  for (size_t i = 0; i < count; ++i) mask[i] = moving.mask[i] * fixed.mask[i];
  // The reference's structure tensor over a patch: anchors where both eigenvalues are large (corners, blobs, the
  // ends of brows and lips), so that the match is defined in both directions.
  Plane jxx(count, 0), jxy(count, 0), jyy(count, 0);
  for (int c = 0; c < 2; ++c)
    for (int y = 1; y < n - 1; ++y)
      for (int x = 1; x < n - 1; ++x) {
        const size_t i = size_t(y) * size_t(n) + size_t(x);
        const float gx = 0.5f * (fixed.channel[c][i + 1] - fixed.channel[c][i - 1]);
        const float gy = 0.5f * (fixed.channel[c][i + size_t(n)] - fixed.channel[c][i - size_t(n)]);
        jxx[i] += gx * gx, jxy[i] += gx * gy, jyy[i] += gy * gy;
      }
  const double sigma = 0.5 * h;
  const Plane sxx = blur(jxx, n, sigma), sxy = blur(jxy, n, sigma), syy = blur(jyy, n, sigma), cover = blur(mask, n, sigma);
  struct Anchor {
    int x, y;
  };
  std::vector<Anchor> anchors;
  std::vector<double> lambda;
  for (int y = h + radius + 1; y < n - h - radius - 1; y += step)
    for (int x = h + radius + 1; x < n - h - radius - 1; x += step) {
      const size_t i = size_t(y) * size_t(n) + size_t(x);
      if (cover[i] < 0.98f) continue;
      const double a = sxx[i], b = sxy[i], c = syy[i];
      lambda.push_back(0.5 * (a + c) - std::sqrt(0.25 * (a - c) * (a - c) + b * b));
      anchors.push_back({x, y});
    }
  // The most structured third of the patches (the rest is skin whose texture the reference averages out).
  const double threshold = lambda.empty() ? 0 : quantile(lambda, 2.0 / 3);
  // Normalised cross-correlation of the reference patch at the anchor with the subject's patch at each offset.
  const int side = 2 * h + 1, offsets = 2 * radius + 1;
  Plane wx(count, 0), wy(count, 0), w(count, 0);
  parallel_for(0, int64_t(anchors.size()), [&](int64_t b0, int64_t b1) {
    std::vector<float> f(size_t(2 * side * side)), g(f.size());
    std::vector<double> score(size_t(offsets * offsets));
    for (int64_t k = b0; k < b1; ++k) {
      if (lambda[size_t(k)] < threshold || lambda[size_t(k)] <= 0) continue;
      const auto [ax, ay] = anchors[size_t(k)];
      const auto patch = [&](const TextureStructure& t, int cx, int cy, std::vector<float>& out) {
        double mean = 0, norm = 0;
        size_t j = 0;
        for (int c = 0; c < 2; ++c)
          for (int y = cy - h; y <= cy + h; ++y)
            for (int x = cx - h; x <= cx + h; ++x) mean += out[j++] = t.channel[c][size_t(y) * size_t(n) + size_t(x)];
        mean /= double(out.size());
        for (float& v : out) v = float(v - mean), norm += double(v) * v;
        return std::sqrt(norm);
      };
      const double fn = patch(fixed, ax, ay, f);
      if (fn <= 0) continue;
      int best = -1;
      for (int oy = -radius; oy <= radius; ++oy)
        for (int ox = -radius; ox <= radius; ++ox) {
          const double gn = patch(moving, ax + ox, ay + oy, g);
          double dot = 0;
          for (size_t j = 0; j < f.size(); ++j) dot += double(f[j]) * g[j];
          const int o = (oy + radius) * offsets + (ox + radius);
          score[size_t(o)] = gn > 0 ? dot / (fn * gn) : -1;
          if (best < 0 || score[size_t(o)] > score[size_t(best)]) best = o;
        }
      const int bx = best % offsets, by = best / offsets;
      if (score[size_t(best)] < 0.6 || bx == 0 || by == 0 || bx == offsets - 1 || by == offsets - 1) continue;
      // Sub-texel peak by a parabola per axis; a flat peak along one axis (an edge) is no anchor.
      const auto at = [&](int xx, int yy) { return score[size_t(yy * offsets + xx)]; };
      const double cxx = at(bx - 1, by) - 2 * at(bx, by) + at(bx + 1, by);
      const double cyy = at(bx, by - 1) - 2 * at(bx, by) + at(bx, by + 1);
      if (cxx > -0.01 || cyy > -0.01) continue;
      const double sx = 0.5 * (at(bx - 1, by) - at(bx + 1, by)) / cxx, sy = 0.5 * (at(bx, by - 1) - at(bx, by + 1)) / cyy;
      const size_t i = size_t(ay) * size_t(n) + size_t(ax);
      const double weight = score[size_t(best)];
      wx[i] = float(weight * (bx - radius - sx));
      wy[i] = float(weight * (by - radius - sy));
      w[i] = float(weight);
    }
  }, 16);
  // Normalised convolution at two scales: near the anchors their displacements spread over a few grid steps, and
  // a field six times wider carries the (smooth) slide across featureless skin between them. Confidence: the matched
  // anchors' density, against a full grid near them and a quarter of one in the wide field (counted half).
  const double near = 1.5 * step, wide = 6 * near;
  const Plane nx = blur(wx, n, near), ny = blur(wy, n, near), nw = blur(w, n, near);
  const Plane fx = blur(wx, n, wide), fy = blur(wy, n, wide), fw = blur(w, n, wide);
  UvFlow out;
  out.size = n;
  out.d.assign(count, Eigen::Vector2f::Zero());
  out.confidence.assign(count, 0.f);
  const float grid = float(step * step), mix = 0.1f;
  for (size_t i = 0; i < count; ++i) {
    const float den = nw[i] + mix * fw[i];
    if (den <= 1e-6f || mask[i] <= 0) continue;
    out.d[i] = Eigen::Vector2f(nx[i] + mix * fx[i], ny[i] + mix * fy[i]) / den;
    out.confidence[i] = std::max(std::min(1.f, nw[i] * grid), 0.5f * std::min(1.f, 4 * fw[i] * grid));
  }
  return out;
}

TextureTargets texture_targets(const Mesh& mesh, const Eigen::MatrixX3d& V, const UvRaster& raster, const UvFlow& flow,
                               const SurfaceLocator& locator, const TextureRefineOptions& options) {
  const Eigen::Index n = mesh.V.rows();
  std::vector<int> uv_of(size_t(n), -1);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) uv_of[size_t(mesh.F(f, k))] = mesh.FUV(f, k);
  std::vector<Eigen::Vector3d> point(static_cast<size_t>(n));
  std::vector<double> confidence(size_t(n), 0.0), moved(size_t(n), 0.0);
  parallel_for(0, n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      if (uv_of[size_t(i)] < 0) continue;
      const Eigen::Vector2d uv = mesh.UV.row(uv_of[size_t(i)]);
      float c = 0;
      const Eigen::Vector2f d = flow.at(uv, &c);
      if (c < options.min_confidence) continue;
      const Eigen::Vector2d target_uv = uv + Eigen::Vector2d(d.x(), -d.y()) / double(flow.size);
      int f = -1;
      Eigen::Vector3d w;
      if (!raster.locate(target_uv, f, w)) continue;
      Eigen::Vector3d p = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) p += w[k] * V.row(mesh.F(f, k)).transpose();
      const Eigen::Vector3d q = locator.locate(p).point;
      moved[size_t(i)] = (q - V.row(i).transpose()).norm();
      if (moved[size_t(i)] > options.max_flow_mm) continue;
      point[size_t(i)] = q;
      confidence[size_t(i)] = c;
    }
  }, 1024);
  TextureTargets t;
  std::vector<double> kept;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (confidence[size_t(i)] <= 0) continue;
    t.vertex.push_back(int(i));
    t.point.push_back(point[size_t(i)]);
    t.confidence.push_back(confidence[size_t(i)]);
    kept.push_back(moved[size_t(i)]);
  }
  if (!kept.empty()) t.median_flow_mm = quantile(kept, 0.5);
  return t;
}

}  // namespace bareskin
