#include "render/pbr.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "render/rasterize.h"
#include "render/sh.h"

namespace bareskin {
namespace {

using RowF3 = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;

float grey(const Image* map, const Eigen::Vector2d& uv, float fallback) {
  return map ? sample_bilinear(*map, uv)[0] : fallback;
}

// Per face: the UV gradient frame (∂p/∂u, ∂p/∂v), for the tangent-space normal map.
void face_tangents(const Mesh& m, Eigen::MatrixX3d& T, Eigen::MatrixX3d& B) {
  T.resize(m.F.rows(), 3);
  B.resize(m.F.rows(), 3);
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d p0 = m.V.row(m.F(f, 0)), e1 = Eigen::Vector3d(m.V.row(m.F(f, 1))) - p0,
                          e2 = Eigen::Vector3d(m.V.row(m.F(f, 2))) - p0;
    const Eigen::Vector2d t0 = m.UV.row(m.FUV(f, 0)), d1 = Eigen::Vector2d(m.UV.row(m.FUV(f, 1))) - t0,
                          d2 = Eigen::Vector2d(m.UV.row(m.FUV(f, 2))) - t0;
    const double det = d1.x() * d2.y() - d2.x() * d1.y();
    if (std::abs(det) < 1e-20) {
      T.row(f).setZero();
      B.row(f).setZero();
      continue;
    }
    T.row(f) = ((e1 * d2.y() - e2 * d1.y()) / det).transpose();
    B.row(f) = ((e2 * d1.x() - e1 * d2.x()) / det).transpose();
  }
}

Eigen::Vector3d mapped_normal(const Eigen::Vector3d& n, const Eigen::Vector3d& t, const Eigen::Vector3d& b,
                              const Eigen::Vector3f& texel) {
  Eigen::Vector3d T = t - n * n.dot(t);
  if (T.squaredNorm() < 1e-20) return n;
  T.normalize();
  Eigen::Vector3d B = n.cross(T);
  if (B.dot(b) < 0) B = -B;  // mirrored UVs
  const Eigen::Vector3d m = (T * (2.0 * texel.x() - 1) + B * (2.0 * texel.y() - 1) + n * (2.0 * texel.z() - 1));
  return m.squaredNorm() > 1e-12 ? m.normalized() : n;
}

// GGX with the height-correlated Smith visibility and Schlick's Fresnel; returns f_spec · π (n · l), which times a key
// light's intensity I is the reflected radiance when the diffuse term is albedo · I (n · l).
double ggx(const Eigen::Vector3d& n, const Eigen::Vector3d& v, const Eigen::Vector3d& l, double rough, double f0) {
  const double nl = n.dot(l), nv = n.dot(v);
  if (nl <= 0 || nv <= 0) return 0;
  const Eigen::Vector3d h = (v + l).normalized();
  const double nh = std::max(0.0, n.dot(h)), vh = std::max(0.0, v.dot(h));
  const double a = std::max(0.002, rough * rough), a2 = a * a;
  const double d = a2 / (M_PI * std::pow(nh * nh * (a2 - 1) + 1, 2));
  const double vis = 0.5 / (nl * std::sqrt(nv * nv * (1 - a2) + a2) + nv * std::sqrt(nl * nl * (1 - a2) + a2));
  const double f = f0 + (1 - f0) * std::pow(1 - vh, 5);
  return d * vis * f * M_PI * nl;
}

void check_diffuse(const PbrMapsView& maps) {
  if (!maps.diffuse || maps.diffuse->color_space != ColorSpace::Linear || maps.diffuse->channels < 3)
    throw InvalidInput("", "the diffuse map must be linear RGB", "convert it with to_linear");
}

}  // namespace

Camera orbit_camera(int size, double yaw_deg, double pitch_deg, const Eigen::Vector3d& target, double distance) {
  Camera c = view_camera("front", size, target, distance);
  c.R = (Eigen::AngleAxisd(pitch_deg * M_PI / 180, Eigen::Vector3d::UnitX()) *
         Eigen::AngleAxisd(-yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
  c.t = -c.R * target - Eigen::Vector3d(0, 0, distance);
  return c;
}

PbrScene::PbrScene(const Mesh& mesh, const Camera& camera, const Image* normal_map)
    : width_(camera.width), height_(camera.height) {
  if (mesh.V.rows() == 0 || mesh.F.rows() == 0 || !mesh.has_uv())
    throw InvalidInput("", "the mesh is empty or has no UVs", "give the avatar's mesh.obj");
  const RasterOutput r = rasterize_mesh(mesh, camera, true);
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> F = mesh.F, FUV = mesh.FUV;
  const RowF3 N = (mesh.has_normals() ? mesh.N : vertex_normals(mesh.V, mesh.F)).cast<float>();
  const RowF3 P = mesh.V.cast<float>();
  const Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor> UV = mesh.UV.cast<float>();
  const std::vector<float> normal = interpolate(r, F.data(), N.data(), 3), pos = interpolate(r, F.data(), P.data(), 3),
                           uv = interpolate(r, FUV.data(), UV.data(), 2);
  Eigen::MatrixX3d T, B;
  if (normal_map) face_tangents(mesh, T, B);
  const Eigen::Vector3d eye = camera.R.transpose() * -camera.t;  // camera centre in the model frame
  for (int64_t i = 0; i < int64_t(width_) * height_; ++i)
    if (r.triangle[size_t(i)] >= 0) pixel_.push_back(i);
  const size_t count = pixel_.size();
  n_.resize(3 * count);
  v_.resize(3 * count);
  uv_.resize(2 * count);
  depth_.resize(count);
  parallel_for(0, int64_t(count), [&](int64_t begin, int64_t end) {
    for (int64_t j = begin; j < end; ++j) {
      const size_t s = size_t(pixel_[size_t(j)]), k = size_t(j);
      const int32_t f = r.triangle[s];
      Eigen::Vector3d n = Eigen::Vector3d(normal[3 * s], normal[3 * s + 1], normal[3 * s + 2]).normalized();
      const Eigen::Vector2d t(uv[2 * s], uv[2 * s + 1]);
      if (normal_map) n = mapped_normal(n, T.row(f), B.row(f), sample_bilinear(*normal_map, t));
      const Eigen::Vector3d p(pos[3 * s], pos[3 * s + 1], pos[3 * s + 2]);
      const Eigen::Vector3d v = (eye - p).normalized();
      for (int c = 0; c < 3; ++c) n_[3 * k + c] = n[c], v_[3 * k + c] = v[c];
      uv_[2 * k] = t.x(), uv_[2 * k + 1] = t.y();
      depth_[k] = r.depth[s];
    }
  }, 4096);
}

Frame PbrScene::shade(const PbrMapsView& maps, const PbrLight& light) const {
  check_diffuse(maps);
  const KeyLight key = light.key.direction.norm() > 0 ? light.key : dominant_light(light.sh);
  Frame out = Frame::blank(width_, height_);
  parallel_for(0, int64_t(pixel_.size()), [&](int64_t begin, int64_t end) {
    for (int64_t j = begin; j < end; ++j) {
      const size_t s = size_t(pixel_[size_t(j)]), k = size_t(j);
      const Eigen::Vector3d n(n_[3 * k], n_[3 * k + 1], n_[3 * k + 2]), v(v_[3 * k], v_[3 * k + 1], v_[3 * k + 2]);
      const Eigen::Vector2d t(uv_[2 * k], uv_[2 * k + 1]);
      const Eigen::Vector3f a = sample_bilinear(*maps.diffuse, t);
      const Eigen::Vector3d S = sh_irradiance(n, light.sh.data());
      const double spec = key.direction.norm() > 0
                              ? ggx(n, v, key.direction, grey(maps.roughness, t, 0.5f), 0.04 * grey(maps.specular, t, 1))
                              : 0;
      for (int c = 0; c < 3; ++c) {
        out.albedo.pixels[3 * s + c] = a[c];
        out.colour.pixels[3 * s + c] = float(std::max(0.0, a[c] * S[c] + spec * key.intensity[c]));
        out.normal.pixels[3 * s + c] = float(0.5 * (n[c] + 1));
      }
      out.depth.pixels[s] = depth_[k];
      out.mask.pixels[s] = 1;
    }
  }, 4096);
  return out;
}

Frame render_pbr(const Mesh& mesh, const Camera& camera, const PbrMapsView& maps, const PbrLight& light) {
  check_diffuse(maps);  // before the rasterization
  return PbrScene(mesh, camera, maps.normal).shade(maps, light);
}

}  // namespace bareskin
