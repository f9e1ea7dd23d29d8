#include "scan/skin_bake.h"

#include <Eigen/Geometry>
#include <cmath>

#include "core/error.h"

namespace bareskin {

SkinBaker::SkinBaker(const SkinSurface& surface, const SkinModel& model) : surface_(surface), model_(model) {
  const Mesh& m = surface.mesh;
  if (!m.has_uv() || !m.has_normals() || surface.template_point.rows() != m.V.rows() ||
      surface.template_uv.rows() != m.V.rows()) {
    throw InternalError("SkinBaker: the surface needs UVs, normals and a template point and UV per vertex");
  }
  tangents_ = uv_tangents(m);
  gradient_map_.resize(size_t(m.F.rows()));
  mm_per_uv_.resize(size_t(m.F.rows()));
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector2d t0 = m.UV.row(m.FUV(f, 0)), d1 = m.UV.row(m.FUV(f, 1)).transpose() - t0,
                          d2 = m.UV.row(m.FUV(f, 2)).transpose() - t0;
    const double det = d1.x() * d2.y() - d2.x() * d1.y();
    Eigen::Matrix3f M = Eigen::Matrix3f::Zero();
    float scale = 0;
    if (std::abs(det) > 1e-20) {
      // Affine maps from atlas UV to the surface (X) and to the template (P): J = [d/du d/dv] (3x2).
      const auto jacobian = [&](const auto& pts) {
        const Eigen::Vector3d p0 = pts.row(m.F(f, 0)), e1 = pts.row(m.F(f, 1)).transpose() - p0,
                              e2 = pts.row(m.F(f, 2)).transpose() - p0;
        Eigen::Matrix<double, 3, 2> J;
        J.col(0) = (e1 * d2.y() - e2 * d1.y()) / det;
        J.col(1) = (e2 * d1.x() - e1 * d2.x()) / det;
        return J;
      };
      const Eigen::Matrix<double, 3, 2> Jx = jacobian(m.V), Jp = jacobian(surface.template_point);
      const Eigen::Matrix2d G = Jx.transpose() * Jx;
      if (std::abs(G.determinant()) > 1e-20) {
        // The surface gradient g of h(P(x)) satisfies g . dX/du = grad h . dP/du (and for v), g in the tangent plane.
        M = (Jx * G.inverse() * Jp.transpose()).cast<float>();
      }
      scale = float(std::sqrt(std::abs(Jp.col(0).cross(Jp.col(1)).norm())));
    }
    gradient_map_[size_t(f)] = M;
    mm_per_uv_[size_t(f)] = scale;
  }
}

Eigen::Matrix3f SkinBaker::frame(int f, const Eigen::Vector3f& b) const {
  return tangent_frame(surface_.mesh, tangents_, f, b);
}

SkinTexel SkinBaker::evaluate(int f, const Eigen::Vector3f& b, float footprint) const {
  const Mesh& m = surface_.mesh;
  Eigen::Vector3f p = Eigen::Vector3f::Zero();
  Eigen::Vector2f uv = Eigen::Vector2f::Zero();
  for (int k = 0; k < 3; ++k) {
    p += b[k] * surface_.template_point.row(m.F(f, k)).cast<float>().transpose();
    uv += b[k] * surface_.template_uv.row(m.F(f, k)).cast<float>().transpose();
  }
  SkinTexel texel;
  const SkinSample skin = model_.sample(p, uv, footprint);
  texel.material = skin.material;
  const Eigen::Matrix3f tbn = frame(f, b);
  // Shading normal: the surface normal tilted by the relief's surface gradient (h pulled back through P).
  const Eigen::Vector3f g = gradient_map_[size_t(f)] * skin.relief_gradient;
  const Eigen::Vector3f shading = (tbn.col(2) - g).normalized();
  texel.normal = (tbn.transpose() * shading).normalized();
  return texel;
}

void SkinBaker::bake(const std::string& dir, const BakeOptions& options, const ProgressCallback& progress) const {
  options.check();
  const float R = float(options.resolution);
  write_uv_maps(surface_.mesh, options, dir, [&](int f, const Eigen::Vector3f& b, int, int) {
    const SkinTexel t = evaluate(f, b, mm_per_uv_[size_t(f)] / R);
    return MapTexel{t.material.diffuse, t.normal, t.material.roughness, t.material.specular};
  }, progress);
}

}  // namespace bareskin
