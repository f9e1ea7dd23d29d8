// Makeup regions in the template UV: binary shapes from the 68 iBUG landmark vertices (polygons, tapered capsules,
// ellipses), turned into signed-distance fields in mm by an exact Euclidean distance transform.
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/mesh.h"
#include "core/parallel.h"
#include "texgen/makeup.h"
#include "texgen/polygon.h"

namespace bareskin::makeup {
namespace {

using Vec2 = Eigen::Vector2d;
using Curve = std::vector<Vec2>;

struct Mask {
  int n = 0;
  std::vector<uint8_t> m;
  explicit Mask(int size) : n(size), m(size_t(size) * size, 0) {}
  uint8_t& at(int x, int y) { return m[size_t(y) * n + x]; }
  uint8_t at(int x, int y) const { return m[size_t(y) * n + x]; }
};

// Texel rows [y0, y1) and columns [x0, x1) a shape with bounding box [lo, hi] (+ margin) can touch.
struct Range {
  int x0, x1, y0, y1;
};
Range texel_range(int n, Vec2 lo, Vec2 hi, double margin) {
  auto clampi = [n](double v) { return std::clamp(int(std::floor(v)), 0, n); };
  return {clampi(lo.x() - margin), clampi(hi.x() + margin + 1), clampi(lo.y() - margin), clampi(hi.y() + margin + 1)};
}

void fill_polygon(Mask& mask, const Curve& poly, bool value = true) {
  bareskin::fill_polygon(poly, mask.n, mask.n, [&](int x, int y) { mask.at(x, y) = value; });
}

// A capsule from a (radius ra) to b (radius rb), radii interpolated along the segment.
void fill_capsule(Mask& mask, const Vec2& a, const Vec2& b, double ra, double rb) {
  const Range r = texel_range(mask.n, a.cwiseMin(b), a.cwiseMax(b), std::max(ra, rb));
  const Vec2 ab = b - a;
  const double len2 = std::max(ab.squaredNorm(), 1e-12);
  for (int y = r.y0; y < r.y1; ++y)
    for (int x = r.x0; x < r.x1; ++x) {
      const Vec2 p(x + 0.5, y + 0.5);
      const double t = std::clamp((p - a).dot(ab) / len2, 0.0, 1.0);
      if ((p - a - t * ab).norm() <= ra + (rb - ra) * t) mask.at(x, y) = 1;
    }
}

void fill_polyline(Mask& mask, const Curve& line, double r0, double r1) {
  for (size_t i = 0; i + 1 < line.size(); ++i) {
    const double t0 = double(i) / double(line.size() - 1), t1 = double(i + 1) / double(line.size() - 1);
    fill_capsule(mask, line[i], line[i + 1], r0 + (r1 - r0) * t0, r0 + (r1 - r0) * t1);
  }
}

// An ellipse with semi-axes (ax along `dir`, ay across it).
void fill_ellipse(Mask& mask, const Vec2& c, Vec2 dir, double ax, double ay) {
  dir.normalize();
  const Vec2 perp(-dir.y(), dir.x());
  const double m = std::max(ax, ay);
  const Range r = texel_range(mask.n, c - Vec2(m, m), c + Vec2(m, m), 1);
  for (int y = r.y0; y < r.y1; ++y)
    for (int x = r.x0; x < r.x1; ++x) {
      const Vec2 p = Vec2(x + 0.5, y + 0.5) - c;
      const double u = p.dot(dir) / ax, v = p.dot(perp) / ay;
      if (u * u + v * v <= 1) mask.at(x, y) = 1;
    }
}

// Catmull-Rom through the points (centripetal-free uniform form), `per` samples per segment; closed or open.
Curve smooth(const Curve& pts, bool closed, int per = 8) {
  const int n = int(pts.size());
  auto P = [&](int i) -> Vec2 {
    if (closed) return pts[size_t(((i % n) + n) % n)];
    return pts[size_t(std::clamp(i, 0, n - 1))];
  };
  Curve out;
  const int segments = closed ? n : n - 1;
  for (int i = 0; i < segments; ++i)
    for (int k = 0; k < per; ++k) {
      const double t = double(k) / per, t2 = t * t, t3 = t2 * t;
      out.push_back(0.5 * ((2 * P(i)) + (-P(i - 1) + P(i + 1)) * t +
                           (2 * P(i - 1) - 5 * P(i) + 4 * P(i + 1) - P(i + 2)) * t2 +
                           (-P(i - 1) + 3 * P(i) - 3 * P(i + 1) + P(i + 2)) * t3));
    }
  if (!closed) out.push_back(pts.back());
  return out;
}

// `count` points evenly spaced by arc length along an open polyline.
Curve resample(const Curve& line, int count) {
  std::vector<double> s(line.size(), 0);
  for (size_t i = 1; i < line.size(); ++i) s[i] = s[i - 1] + (line[i] - line[i - 1]).norm();
  Curve out;
  size_t j = 0;
  for (int k = 0; k < count; ++k) {
    const double target = s.back() * k / (count - 1);
    while (j + 2 < line.size() && s[j + 1] < target) ++j;
    const double seg = std::max(s[j + 1] - s[j], 1e-12);
    out.push_back(line[j] + (line[j + 1] - line[j]) * std::clamp((target - s[j]) / seg, 0.0, 1.0));
  }
  return out;
}

Curve lerp(const Curve& a, const Curve& b, double t) {
  Curve out(a.size());
  for (size_t i = 0; i < a.size(); ++i) out[i] = a[i] + t * (b[i] - a[i]);
  return out;
}

// The closed polygon between two open curves of the same direction.
Curve band(const Curve& a, const Curve& b) {
  Curve out = a;
  out.insert(out.end(), b.rbegin(), b.rend());
  return out;
}

// Squared distance transform of one line (Felzenszwalb & Huttenlocher 2012): f sampled at 0..n-1 -> d. "No site" is a
// large finite value (kFar), which keeps the parabola intersections finite.
constexpr double kFar = 1e20;
void edt_1d(const std::vector<double>& f, std::vector<double>& d, std::vector<int>& v, std::vector<double>& z) {
  const int n = int(f.size());
  const double inf = std::numeric_limits<double>::infinity();
  int k = 0;
  v[0] = 0;
  z[0] = -inf;
  z[1] = inf;
  for (int q = 1; q < n; ++q) {
    double s;
    while (true) {
      const int p = v[size_t(k)];
      s = ((f[size_t(q)] + double(q) * q) - (f[size_t(p)] + double(p) * p)) / (2.0 * q - 2.0 * p);
      if (s > z[size_t(k)]) break;
      --k;
    }
    ++k;
    v[size_t(k)] = q;
    z[size_t(k)] = s;
    z[size_t(k) + 1] = inf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[size_t(k) + 1] < q) ++k;
    const int p = v[size_t(k)];
    d[size_t(q)] = (double(q) - p) * (q - p) + f[size_t(p)];
  }
}

// Euclidean distance (texels) from every texel of a w x h mask (row-major) to the nearest texel whose mask equals
// `target`.
std::vector<double> distance_to(const std::vector<uint8_t>& mask, int w, int h, uint8_t target) {
  const int n = std::max(w, h);
  std::vector<double> grid(size_t(w) * h), f(n), d(n), z(n + 1);
  std::vector<int> v(n);
  for (size_t i = 0; i < grid.size(); ++i) grid[i] = (mask[i] != 0) == (target != 0) ? 0 : kFar;
  f.resize(size_t(h)), d.resize(size_t(h));
  for (int x = 0; x < w; ++x) {
    for (int y = 0; y < h; ++y) f[size_t(y)] = grid[size_t(y) * w + x];
    edt_1d(f, d, v, z);
    for (int y = 0; y < h; ++y) grid[size_t(y) * w + x] = d[size_t(y)];
  }
  f.resize(size_t(w)), d.resize(size_t(w));
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) f[size_t(x)] = grid[size_t(y) * w + x];
    edt_1d(f, d, v, z);
    for (int x = 0; x < w; ++x) grid[size_t(y) * w + x] = std::sqrt(d[size_t(x)]);
  }
  return grid;
}

// Signed distance in mm (negative inside), the boundary half way between an inside and an outside texel centre. An
// empty mask is everywhere far outside. Only distances up to kMaxReachMm matter (paint, reach_box), so the transform
// runs on the mask's bounding box grown by a margin beyond that reach; it is exact there (an inside texel's nearest
// outside texel is at most the margin away, and no texel outside the window is nearer to the mask than the window's
// own outside ring), and the texels beyond the window are far (1e3 mm) as for an empty mask.
Image signed_distance(const Mask& mask, double mm_per_texel) {
  Image out(mask.n, mask.n, 1, ColorSpace::Data, float(1e3));
  int x0 = mask.n, x1 = -1, y0 = mask.n, y1 = -1;
  for (int y = 0; y < mask.n; ++y)
    for (int x = 0; x < mask.n; ++x)
      if (mask.m[size_t(y) * mask.n + x]) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
  if (x1 < 0) return out;
  const int margin = int(std::ceil((kMaxReachMm + 2) / mm_per_texel)) + 2;
  x0 = std::max(0, x0 - margin), y0 = std::max(0, y0 - margin);
  x1 = std::min(mask.n - 1, x1 + margin), y1 = std::min(mask.n - 1, y1 + margin);
  const int w = x1 - x0 + 1, h = y1 - y0 + 1;
  std::vector<uint8_t> window(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) window[size_t(y) * w + x] = mask.m[size_t(y + y0) * mask.n + x + x0];
  const std::vector<double> to_in = distance_to(window, w, h, 1), to_out = distance_to(window, w, h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      const double d = window[i] ? -(std::min(to_out[i], 1e6) - 0.5) : to_in[i] - 0.5;
      out.at(x + x0, y + y0) = float(d * mm_per_texel);
    }
  return out;
}

std::array<int, 4> reach_box(const Image& distance) {
  int x0 = distance.width, x1 = 0, y0 = distance.height, y1 = 0;
  for (int y = 0; y < distance.height; ++y)
    for (int x = 0; x < distance.width; ++x)
      if (distance.at(x, y) <= kMaxReachMm) {
        x0 = std::min(x0, x), x1 = std::max(x1, x + 1), y0 = std::min(y0, y), y1 = std::max(y1, y + 1);
      }
  if (x1 <= x0) return {0, 0, 0, 0};
  return {x0, x1, y0, y1};
}

void rasterize_coverage(const Mesh& mesh, const Eigen::MatrixX2d& uv, int n, Mask& mask) {
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    Vec2 p[3];
    for (int c = 0; c < 3; ++c) p[c] = Vec2(uv(mesh.F(f, c), 0) * n, (1 - uv(mesh.F(f, c), 1)) * n);
    const double area = (p[1] - p[0]).x() * (p[2] - p[0]).y() - (p[2] - p[0]).x() * (p[1] - p[0]).y();
    if (std::abs(area) < 1e-12) continue;
    const Range r = texel_range(n, p[0].cwiseMin(p[1]).cwiseMin(p[2]), p[0].cwiseMax(p[1]).cwiseMax(p[2]), 0);
    for (int y = r.y0; y < r.y1; ++y)
      for (int x = r.x0; x < r.x1; ++x) {
        const Vec2 q(x + 0.5, y + 0.5);
        double w[3];
        for (int c = 0; c < 3; ++c) {
          const Vec2& a = p[(c + 1) % 3];
          const Vec2& b = p[(c + 2) % 3];
          w[c] = ((b - a).x() * (q - a).y() - (q - a).x() * (b - a).y()) / area;
        }
        if (w[0] >= -1e-9 && w[1] >= -1e-9 && w[2] >= -1e-9) mask.at(x, y) = 1;
      }
  }
}

// The landmark geometry every region is drawn from, in texels.
struct Face {
  std::vector<Vec2> L;
  double mm;  // texels per mm
  Vec2 down;  // texel direction of the face's "down" (chin side), unit
  Vec2 P(int k) const { return L[size_t(k)]; }
  Curve pts(std::initializer_list<int> ids) const {
    Curve c;
    for (int k : ids) c.push_back(P(k));
    return c;
  }
  // Per side (0: iBUG 36-41 / brow 17-21, 1: 42-47 / 22-26), curves from the outer eye corner to the inner one.
  Curve upper_lid(int s) const {
    return resample(smooth(s ? pts({45, 44, 43, 42}) : pts({36, 37, 38, 39}), false), 32);
  }
  Curve lower_lid(int s) const {
    return resample(smooth(s ? pts({45, 46, 47, 42}) : pts({36, 41, 40, 39}), false), 32);
  }
  Curve brow(int s) const {
    return resample(smooth(s ? pts({26, 25, 24, 23, 22}) : pts({17, 18, 19, 20, 21}), false), 32);
  }
  Curve eye(int s) const { return smooth(s ? pts({42, 43, 44, 45, 46, 47}) : pts({36, 37, 38, 39, 40, 41}), true); }
  Vec2 outer_corner(int s) const { return s ? P(45) : P(36); }
  Vec2 inner_corner(int s) const { return s ? P(42) : P(39); }
};

void draw_eyes(const Face& f, Mask& m) {
  for (int s = 0; s < 2; ++s) fill_polygon(m, f.eye(s));
}

// The outer lip contour; the mouth opening (60-67) stays in: the template's mouth is closed, and lipstick carries
// onto the inner lip.
void draw_lips(const Face& f, Mask& m) {
  fill_polygon(m, smooth(f.pts({48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59}), true));
}

void draw_brows(const Face& f, Mask& m) {
  // As the procedural skin draws them: the landmark polyline 1.5 mm lower, 4.5 mm half-width at the nose, 2 mm outside.
  for (int s = 0; s < 2; ++s) {
    Curve b = f.brow(s);
    for (Vec2& p : b) p += f.down * 1.5 * f.mm;
    fill_polyline(m, b, 2.0 * f.mm, 4.5 * f.mm);
  }
}

void draw_nostrils(const Face& f, Mask& m) {
  const Vec2 across = (f.P(35) - f.P(31)).normalized();
  for (const auto& [a, b] : {std::pair{31, 32}, std::pair{34, 35}}) {
    const Vec2 c = 0.5 * (f.P(a) + f.P(b)) - f.down * 1.0 * f.mm;
    fill_ellipse(m, c, across, 2.8 * f.mm, 1.6 * f.mm);
  }
}

void draw_region(Region r, const Face& f, const Mask& coverage, Mask& m) {
  const double mm = f.mm;
  switch (r) {
    case Region::Face: {
      m.m = coverage.m;
      Mask cut(m.n);
      draw_eyes(f, cut);
      draw_brows(f, cut);
      draw_lips(f, cut);
      fill_polygon(cut, smooth(f.pts({60, 61, 62, 63, 64, 65, 66, 67}), true));
      draw_nostrils(f, cut);
      for (size_t i = 0; i < m.m.size(); ++i) m.m[i] = m.m[i] && !cut.m[i];
      break;
    }
    case Region::UnderEye:
      for (int s = 0; s < 2; ++s) {
        const Curve lid = f.lower_lid(s);
        Curve low = lid;
        for (size_t i = 0; i < low.size(); ++i) {
          const double t = double(i) / double(low.size() - 1);  // 0 outer .. 1 inner
          low[i] += f.down * (1.5 + 8.0 * std::sin(M_PI * (0.15 + 0.8 * t))) * mm;
        }
        Curve top = lid;
        for (Vec2& p : top) p += f.down * 0.6 * mm;
        fill_polygon(m, band(top, low));
      }
      break;
    case Region::Cheeks:
      for (int s = 0; s < 2; ++s) {
        const Vec2 apple = s ? (f.P(14) + f.P(35) + f.P(46)) / 3 : (f.P(2) + f.P(31) + f.P(41)) / 3;
        const Vec2 temple = s ? f.P(16) : f.P(0);
        const Vec2 dir = temple - (s ? f.P(35) : f.P(31));
        fill_ellipse(m, apple + 0.15 * (temple - apple), dir, 15 * mm, 10 * mm);
      }
      break;
    case Region::Cheekbones:
      for (int s = 0; s < 2; ++s) {
        const Vec2 ear = s ? f.P(16) + 0.6 * (f.P(15) - f.P(16)) : f.P(0) + 0.6 * (f.P(1) - f.P(0));
        const Vec2 mouth = s ? f.P(54) : f.P(48);
        const Vec2 start = ear + (mouth - ear).normalized() * 4 * mm;
        fill_capsule(m, start, start + 0.5 * (mouth - start), 4.5 * mm, 2.0 * mm);
      }
      break;
    case Region::Jaw: {
      Curve left = f.pts({2, 3, 4, 5, 6}), right = f.pts({14, 13, 12, 11, 10});
      const Vec2 centre = f.P(33);
      for (Curve* c : {&left, &right}) {
        for (Vec2& p : *c) p += (centre - p).normalized() * 3.5 * mm;
        fill_polyline(m, smooth(*c, false), 4.5 * mm, 2.5 * mm);
      }
      break;
    }
    case Region::NoseSides:
      for (int s = 0; s < 2; ++s) {
        const Vec2 top = f.P(27) + 0.45 * ((s ? f.P(22) : f.P(21)) - f.P(27));
        const Vec2 wing = (s ? f.P(35) : f.P(31)) - f.down * 3.5 * mm;
        fill_capsule(m, top, wing, 1.2 * mm, 1.8 * mm);
      }
      break;
    case Region::Lips:
      draw_lips(f, m);
      break;
    case Region::LipCentre: {
      const Vec2 across = f.P(54) - f.P(48);
      const double width = across.norm();
      const Vec2 lower = 0.5 * (f.P(57) + f.P(66)), upper = 0.5 * (f.P(51) + f.P(62));
      fill_ellipse(m, lower, across, 0.22 * width, std::max(0.3 * (f.P(57) - f.P(66)).norm(), 1.0 * mm));
      fill_ellipse(m, upper, across, 0.12 * width, std::max(0.25 * (f.P(51) - f.P(62)).norm(), 0.8 * mm));
      Mask lips(m.n);
      draw_lips(f, lips);
      for (size_t i = 0; i < m.m.size(); ++i) m.m[i] = m.m[i] && lips.m[i];
      break;
    }
    case Region::Lids:
      for (int s = 0; s < 2; ++s) fill_polygon(m, band(f.upper_lid(s), lerp(f.upper_lid(s), f.brow(s), 0.45)));
      break;
    case Region::Crease:
      for (int s = 0; s < 2; ++s) {
        const Curve u = f.upper_lid(s), b = f.brow(s);
        fill_polygon(m, band(lerp(u, b, 0.3), lerp(u, b, 0.62)));
      }
      break;
    case Region::Smoky:
      for (int s = 0; s < 2; ++s) {
        const Curve u = f.upper_lid(s);
        fill_polygon(m, band(u, lerp(u, f.brow(s), 0.6)));
        Curve low = f.lower_lid(s);
        for (Vec2& p : low) p += f.down * 1.0 * mm;
        fill_polyline(m, low, 2.2 * mm, 1.0 * mm);
        const Vec2 out = (f.outer_corner(s) - f.inner_corner(s)).normalized();
        fill_capsule(m, f.outer_corner(s), f.outer_corner(s) + out * 6 * mm - f.down * 3 * mm, 4 * mm, 2 * mm);
      }
      break;
    case Region::LashLine:
      for (int s = 0; s < 2; ++s) {
        Curve u = f.upper_lid(s);
        for (Vec2& p : u) p -= f.down * 0.3 * mm;
        fill_polyline(m, u, 1.0 * mm, 0.6 * mm);
      }
      break;
    case Region::Wing:
      for (int s = 0; s < 2; ++s) {
        const Vec2 out = (f.outer_corner(s) - f.inner_corner(s)).normalized();
        const Vec2 dir = (out * std::cos(0.4) - f.down * std::sin(0.4)).normalized();
        const Vec2 start = f.outer_corner(s) - f.down * 0.4 * mm;
        fill_capsule(m, start, start + dir * 7 * mm, 1.0 * mm, 0.2 * mm);
      }
      break;
    case Region::Brows:
      draw_brows(f, m);
      break;
    case Region::EyePaint:
      for (int s = 0; s < 2; ++s) {
        Vec2 c = Vec2::Zero();
        for (const Vec2& p : f.eye(s)) c += p;
        c /= double(f.eye(s).size());
        const Vec2 out = f.outer_corner(s) - f.inner_corner(s);
        fill_ellipse(m, c + out.normalized() * 3 * mm - f.down * 3 * mm, out, 22 * mm, 17 * mm);
      }
      break;
    case Region::CheekPaint:
      for (int s = 0; s < 2; ++s) {
        const Vec2 apple = s ? (f.P(14) + f.P(35) + f.P(46)) / 3 : (f.P(2) + f.P(31) + f.P(41)) / 3;
        const Vec2 temple = s ? f.P(16) : f.P(0);
        fill_ellipse(m, apple + 0.35 * (temple - apple), temple - apple, 22 * mm, 13 * mm);
      }
      break;
  }
}

}  // namespace

std::vector<Eigen::Vector2d> landmark_texels(const TemplateFace& face, int uv_size) {
  if (face.landmark_vertices.size() != 68) {
    throw InvalidInput("template", "makeup regions need the 68 iBUG landmark vertices",
                       "give the template's landmarks.json");
  }
  Eigen::MatrixX2d uv;
  if (!per_vertex_uv(face.mesh, uv)) {
    throw InvalidInput("template", "makeup regions need one UV per vertex (no seams)", "use a seamless template UV");
  }
  std::vector<Vec2> out;
  for (int v : face.landmark_vertices) {
    if (v < 0 || v >= uv.rows())
      throw InvalidInput("template", "a landmark vertex id is out of range", "check landmarks.json");
    out.emplace_back(uv(v, 0) * uv_size, (1 - uv(v, 1)) * uv_size);
  }
  return out;
}

MakeupRegions makeup_regions(const TemplateFace& face, int uv_size, const std::set<Region>& only) {
  if (uv_size < 32 || uv_size > 8192) {
    throw InvalidInput("makeup", "UV size " + std::to_string(uv_size) + " is out of range", "use 32..8192 texels");
  }
  MakeupRegions out;
  out.uv_size = uv_size;
  Face f;
  f.L = landmark_texels(face, uv_size);
  Eigen::MatrixX2d uv;
  per_vertex_uv(face.mesh, uv);
  double area_uv = 0;
  for (Eigen::Index t = 0; t < face.mesh.F.rows(); ++t) {
    const Vec2 a = uv.row(face.mesh.F(t, 0)), b = uv.row(face.mesh.F(t, 1)), c = uv.row(face.mesh.F(t, 2));
    area_uv += 0.5 * std::abs((b - a).x() * (c - a).y() - (c - a).x() * (b - a).y());
  }
  if (area_uv <= 0) throw InvalidInput("template", "the UV layout has no area", "use a template with a UV layout");
  out.mm_per_texel = std::sqrt(surface_area(face.mesh.V, face.mesh.F) / area_uv) / uv_size;
  f.mm = 1.0 / out.mm_per_texel;
  f.down = (f.P(8) - f.P(27)).normalized();  // chin below the nose bridge

  Mask coverage(uv_size);
  rasterize_coverage(face.mesh, uv, uv_size, coverage);
  out.coverage = Image(uv_size, uv_size, 1, ColorSpace::Data);
  for (size_t i = 0; i < coverage.m.size(); ++i) out.coverage.pixels[i] = coverage.m[i];

  Mask eyes(uv_size);
  draw_eyes(f, eyes);
  const Image eye_distance = signed_distance(eyes, out.mm_per_texel);
  out.exclusion = Image(uv_size, uv_size, 1, ColorSpace::Data);
  for (size_t i = 0; i < eyes.m.size(); ++i) {
    const float t = std::clamp((0.3f - eye_distance.pixels[i]) / 0.6f, 0.0f, 1.0f);
    out.exclusion.pixels[i] = t * t * (3 - 2 * t);
  }
  std::vector<int> wanted;  // Face always (skin_tone); the others when asked for, or all
  for (int r = 0; r < kRegionCount; ++r)
    if (only.empty() || only.count(Region(r)) || Region(r) == Region::Face) wanted.push_back(r);
  parallel_for(0, int64_t(wanted.size()), [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const int r = wanted[size_t(i)];
      Mask m(uv_size);
      draw_region(Region(r), f, coverage, m);
      out.distance[size_t(r)] = signed_distance(m, out.mm_per_texel);
      out.box[size_t(r)] = reach_box(out.distance[size_t(r)]);
    }
  });
  return out;
}

}  // namespace bareskin::makeup
