#include "render/preview.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "core/error.h"

namespace bareskin {
namespace {

// Projects a vertex to (x, y) pixels and depth (larger = nearer) for the view.
struct Projection {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  double scale = 1, half = 0;
  Eigen::Vector3d operator()(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d q = rotation * (p - center);
    return {half + scale * q.x(), half - scale * q.y(), q.z()};
  }
};

void blend(Image& img, int x, int y, const Eigen::Vector3f& colour, float alpha) {
  if (x < 0 || y < 0 || x >= img.width || y >= img.height) return;
  for (int c = 0; c < 3; ++c) img.at(x, y, c) = img.at(x, y, c) * (1 - alpha) + colour[c] * alpha;
}

// Anti-aliasing is not needed for QA pictures; a DDA line with per-pixel depth test against the z-buffer (with a
// small bias) hides the edges behind the surface.
void draw_line(Image& img, const std::vector<float>* depth, Eigen::Vector3d a, Eigen::Vector3d b,
               const Eigen::Vector3f& colour, float alpha, double bias) {
  const int steps = int(std::ceil(std::max(std::abs(b.x() - a.x()), std::abs(b.y() - a.y())))) + 1;
  for (int i = 0; i <= steps; ++i) {
    const Eigen::Vector3d p = a + (b - a) * (double(i) / steps);
    const int x = int(std::lround(p.x())), y = int(std::lround(p.y()));
    if (x < 0 || y < 0 || x >= img.width || y >= img.height) continue;
    if (depth && p.z() + bias < (*depth)[size_t(y) * img.width + x]) continue;
    blend(img, x, y, colour, alpha);
  }
}

void draw_dot(Image& img, const Eigen::Vector3d& p, int radius, const Eigen::Vector3f& colour) {
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      if (dx * dx + dy * dy <= radius * radius) blend(img, int(std::lround(p.x())) + dx, int(std::lround(p.y())) + dy, colour, 1);
    }
  }
}

}  // namespace

void draw_landmarks(Image& image, const Eigen::MatrixXd& points, const Eigen::Vector3f& colour, int radius) {
  auto at = [&](int i) { return Eigen::Vector3d(points(i, 0) - 0.5, points(i, 1) - 0.5, 0); };
  if (points.rows() == 68) {
    // iBUG-68 outlines: [first, last, closed]
    const int parts[9][3] = {{0, 16, 0}, {17, 21, 0}, {22, 26, 0}, {27, 30, 0}, {31, 35, 0},
                             {36, 41, 1}, {42, 47, 1}, {48, 59, 1}, {60, 67, 1}};
    for (const auto& part : parts) {
      for (int i = part[0]; i < part[1]; ++i) draw_line(image, nullptr, at(i), at(i + 1), colour, 0.6f, 0);
      if (part[2]) draw_line(image, nullptr, at(part[1]), at(part[0]), colour, 0.6f, 0);
    }
  }
  for (int i = 0; i < points.rows(); ++i) draw_dot(image, at(i), radius, colour);
}

void draw_box(Image& image, double x, double y, double width, double height, const Eigen::Vector3f& colour) {
  const Eigen::Vector3d corners[4] = {{x - 0.5, y - 0.5, 0}, {x + width - 0.5, y - 0.5, 0},
                                      {x + width - 0.5, y + height - 0.5, 0}, {x - 0.5, y + height - 0.5, 0}};
  for (int i = 0; i < 4; ++i) draw_line(image, nullptr, corners[i], corners[(i + 1) % 4], colour, 1, 0);
}

PreviewView parse_preview_view(const std::string& name) {
  if (name == "front") return PreviewView::Front;
  if (name == "left") return PreviewView::Left;
  if (name == "right") return PreviewView::Right;
  if (name == "uv") return PreviewView::UV;
  throw InvalidInput("", "unknown view '" + name + "'", "use front, left, right or uv");
}

Eigen::Vector3f heat_color(double t) {
  // Piecewise-linear through blue, cyan, green, yellow, red.
  static const float stops[5][3] = {{0.15f, 0.25f, 0.85f}, {0.1f, 0.75f, 0.85f}, {0.3f, 0.8f, 0.3f}, {0.95f, 0.85f, 0.2f},
                                    {0.85f, 0.15f, 0.1f}};
  const double x = std::clamp(t, 0.0, 1.0) * 4;
  const int i = std::min(3, int(x));
  const float f = float(x - i);
  return {stops[i][0] + f * (stops[i + 1][0] - stops[i][0]), stops[i][1] + f * (stops[i + 1][1] - stops[i][1]),
          stops[i][2] + f * (stops[i + 1][2] - stops[i][2])};
}

void PreviewOptions::check() const {
  if (size < 16 || size > 16384) throw InvalidInput("", "--size must lie in [16, 16384]", "");
  if (!(wire_opacity >= 0 && wire_opacity <= 1)) throw InvalidInput("", "the wireframe's opacity must lie in [0, 1]", "");
  if (vertex_colors.rows() > 0 && !vertex_colors.allFinite())
    throw InvalidInput("", "the vertex colours are not finite", "give sRGB colours in [0, 1]");
}

Image render_preview(const Mesh& mesh, const PreviewOptions& options) {
  options.check();
  for (int v : options.landmark_vertices)
    if (v < 0 || v >= mesh.V.rows()) throw InvalidInput("", "landmark vertex " + std::to_string(v) + " is not in the mesh", "");
  Image img(options.size, options.size, 3, ColorSpace::sRGB, 1.f);
  const Eigen::Vector3f wire(0.05f, 0.1f, 0.3f), red(0.85f, 0.1f, 0.1f);
  const int dot = std::max(2, options.size / 200);

  if (options.view == PreviewView::UV) {
    if (!mesh.has_uv()) throw InvalidInput("", "mesh has no UVs to draw", "choose a 3D view");
    const auto to_px = [&](const Eigen::RowVector2d& uv) {
      return Eigen::Vector3d(uv.x() * (options.size - 1), (1.0 - uv.y()) * (options.size - 1), 0);
    };
    for (Eigen::Index f = 0; f < mesh.FUV.rows(); ++f) {
      for (int k = 0; k < 3; ++k) {
        draw_line(img, nullptr, to_px(mesh.UV.row(mesh.FUV(f, k))), to_px(mesh.UV.row(mesh.FUV(f, (k + 1) % 3))), wire,
                  float(options.wire_opacity), 0);
      }
    }
    // A landmark vertex's UV: the first corner that uses it.
    std::vector<int> uv_of(size_t(mesh.V.rows()), -1);
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
      for (int k = 0; k < 3; ++k) uv_of[size_t(mesh.F(f, k))] = mesh.FUV(f, k);
    for (int v : options.landmark_vertices) {
      if (uv_of[size_t(v)] >= 0) draw_dot(img, to_px(mesh.UV.row(uv_of[size_t(v)])), dot, red);
    }
    return img;
  }

  Projection proj;
  if (options.view != PreviewView::Front) {
    proj.rotation = Eigen::AngleAxisd(options.view == PreviewView::Left ? -M_PI / 2 : M_PI / 2, Eigen::Vector3d::UnitY())
                        .toRotationMatrix();
  }
  Eigen::MatrixX3d P = (mesh.V * proj.rotation.transpose());
  const Eigen::Vector3d lo = P.colwise().minCoeff(), hi = P.colwise().maxCoeff();
  proj.center = proj.rotation.transpose() * ((lo + hi) / 2);
  proj.half = options.size / 2.0;
  proj.scale = 0.9 * options.size / std::max((hi - lo).x(), (hi - lo).y());
  std::vector<Eigen::Vector3d> screen(size_t(mesh.V.rows()));
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) screen[size_t(i)] = proj(mesh.V.row(i).transpose());
  const Eigen::MatrixX3d N = mesh.has_normals() ? mesh.N : vertex_normals(mesh.V, mesh.F);
  const Eigen::Vector3d light = proj.rotation.transpose() * Eigen::Vector3d(0.3, 0.4, 1).normalized();

  std::optional<Image> albedo;
  if (options.texture) {
    if (!mesh.has_uv()) throw InvalidInput("", "mesh has no UVs to map a texture with", "give a mesh with UVs");
    albedo = options.texture->color_space == ColorSpace::sRGB ? to_linear(*options.texture) : *options.texture;
  }
  std::vector<float> depth(size_t(options.size) * options.size, -std::numeric_limits<float>::infinity());
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector3d &a = screen[size_t(mesh.F(f, 0))], &b = screen[size_t(mesh.F(f, 1))], &c = screen[size_t(mesh.F(f, 2))];
    const double area = (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
    if (area >= 0) continue;  // back-facing (y points down on screen, so front faces have negative area)
    const int x0 = std::max(0, int(std::floor(std::min({a.x(), b.x(), c.x()})))),
              x1 = std::min(options.size - 1, int(std::ceil(std::max({a.x(), b.x(), c.x()})))),
              y0 = std::max(0, int(std::floor(std::min({a.y(), b.y(), c.y()})))),
              y1 = std::min(options.size - 1, int(std::ceil(std::max({a.y(), b.y(), c.y()}))));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double w0 = ((b.x() - px) * (c.y() - py) - (b.y() - py) * (c.x() - px)) / area;
        const double w1 = ((c.x() - px) * (a.y() - py) - (c.y() - py) * (a.x() - px)) / area;
        const double w2 = 1 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const double z = w0 * a.z() + w1 * b.z() + w2 * c.z();
        float& d = depth[size_t(y) * options.size + x];
        if (z <= d) continue;
        d = float(z);
        const Eigen::Vector3d n =
            (w0 * N.row(mesh.F(f, 0)) + w1 * N.row(mesh.F(f, 1)) + w2 * N.row(mesh.F(f, 2))).transpose().normalized();
        const float shade = options.shaded ? float(0.15 + 0.8 * std::max(0.0, n.dot(light))) : 1.0f;
        if (albedo) {
          const Eigen::Vector2d uv = w0 * mesh.UV.row(mesh.FUV(f, 0)) + w1 * mesh.UV.row(mesh.FUV(f, 1)) +
                                     w2 * mesh.UV.row(mesh.FUV(f, 2));
          const Eigen::Vector3f c = sample_bilinear(*albedo, uv);
          for (int k = 0; k < 3; ++k) img.at(x, y, k) = linear_to_srgb(std::min(1.0f, shade * c[k]));
        } else if (options.vertex_colors.rows() == mesh.V.rows() && mesh.V.rows() > 0) {
          const Eigen::Vector3f c = (float(w0) * options.vertex_colors.row(mesh.F(f, 0)) +
                                     float(w1) * options.vertex_colors.row(mesh.F(f, 1)) +
                                     float(w2) * options.vertex_colors.row(mesh.F(f, 2))).transpose();
          for (int k = 0; k < 3; ++k) img.at(x, y, k) = linear_to_srgb(std::min(1.0f, shade * srgb_to_linear(c[k])));
        } else if (options.shaded) {
          for (int k = 0; k < 3; ++k) img.at(x, y, k) = shade * (k == 2 ? 0.92f : 0.85f) + 0.05f;
        }
      }
    }
  }
  if (options.wireframe) {
    const double bias = 0.002 * (hi - lo).norm();
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
      for (int k = 0; k < 3; ++k) {
        const int i = mesh.F(f, k), j = mesh.F(f, (k + 1) % 3);
        if (i < j) draw_line(img, &depth, screen[size_t(i)], screen[size_t(j)], wire, float(options.wire_opacity), bias);
      }
    }
  }
  for (int v : options.landmark_vertices) {
    const Eigen::Vector3d p = screen[size_t(v)];
    const int x = int(p.x()), y = int(p.y());
    const bool visible = x >= 0 && y >= 0 && x < options.size && y < options.size &&
                         p.z() + 0.01 * (hi - lo).norm() >= depth[size_t(y) * options.size + x];
    if (visible) draw_dot(img, p, dot, red);
  }
  return img;
}

}  // namespace bareskin
