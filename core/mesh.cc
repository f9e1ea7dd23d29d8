#include "core/mesh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <tuple>
#include <utility>
#include <vector>

#include "core/error.h"

namespace bareskin {

void validate(const Mesh& m, const std::string& source) {
  const auto where = [&](const char* what, Eigen::Index i) { return std::string(what) + " " + std::to_string(i); };
  for (Eigen::Index i = 0; i < m.V.rows(); ++i) {
    if (!m.V.row(i).allFinite()) {
      throw InvalidInput(source, where("vertex", i) + " is NaN or infinite", "repair or remove that vertex");
    }
  }
  const Eigen::Index nv = m.V.rows();
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      if (m.F(f, c) < 0 || m.F(f, c) >= nv) {
        throw InvalidInput(source, where("face", f) + " refers to vertex " + std::to_string(m.F(f, c)) + " but there are " +
                                       std::to_string(nv) + " vertices",
                           "the file is truncated or corrupt");
      }
    }
    if (m.F(f, 0) == m.F(f, 1) || m.F(f, 1) == m.F(f, 2) || m.F(f, 0) == m.F(f, 2)) {
      throw InvalidInput(source, where("face", f) + " uses one vertex twice", "remove degenerate faces");
    }
  }
  if (m.UV.rows() > 0 || m.FUV.rows() > 0) {
    if (m.FUV.rows() != m.F.rows()) {
      throw InvalidInput(source, "has UVs for " + std::to_string(m.FUV.rows()) + " faces but " + std::to_string(m.F.rows()) +
                                     " faces",
                         "give every face UVs or none");
    }
    for (Eigen::Index i = 0; i < m.UV.rows(); ++i) {
      if (!m.UV.row(i).allFinite()) throw InvalidInput(source, where("texture coordinate", i) + " is NaN or infinite", "");
    }
    for (Eigen::Index f = 0; f < m.FUV.rows(); ++f) {
      for (int c = 0; c < 3; ++c) {
        if (m.FUV(f, c) < 0 || m.FUV(f, c) >= m.UV.rows()) {
          throw InvalidInput(source, where("face", f) + " refers to texture coordinate " + std::to_string(m.FUV(f, c)) +
                                         " but there are " + std::to_string(m.UV.rows()),
                             "the file is truncated or corrupt");
        }
      }
    }
  }
  if (m.N.rows() > 0 && m.N.rows() != m.V.rows()) {
    throw InvalidInput(source, "has " + std::to_string(m.N.rows()) + " normals for " + std::to_string(nv) + " vertices", "");
  }
}

Eigen::MatrixX3d face_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  Eigen::MatrixX3d N(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    const double len = n.norm();
    N.row(f) = len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
  }
  return N;
}

Eigen::MatrixX3d vertex_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  Eigen::MatrixX3d N = Eigen::MatrixX3d::Zero(V.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::RowVector3d n = (b - a).cross(c - a).transpose();  // length = 2 * area: area weighting
    for (int k = 0; k < 3; ++k) N.row(F(f, k)) += n;
  }
  for (Eigen::Index i = 0; i < N.rows(); ++i) {
    const double len = N.row(i).norm();
    if (len > 0) N.row(i) /= len;
  }
  return N;
}

Eigen::MatrixX2i boundary_edges(const Eigen::MatrixX3i& F) {
  // Undirected edges sorted so that shared edges sit side by side; an edge seen once is on the boundary.
  struct Edge {
    int lo, hi, a, b;
  };
  std::vector<Edge> edges;
  edges.reserve(size_t(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    for (int k = 0; k < 3; ++k) {
      const int a = F(f, k), b = F(f, (k + 1) % 3);
      edges.push_back({std::min(a, b), std::max(a, b), a, b});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const Edge& x, const Edge& y) { return std::tie(x.lo, x.hi) < std::tie(y.lo, y.hi); });
  std::vector<std::pair<int, int>> boundary;
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
    if (j - i == 1) boundary.emplace_back(edges[i].a, edges[i].b);
    i = j;
  }
  Eigen::MatrixX2i E(boundary.size(), 2);
  for (size_t i = 0; i < boundary.size(); ++i) E.row(Eigen::Index(i)) << boundary[i].first, boundary[i].second;
  return E;
}

bool per_vertex_uv(const Mesh& mesh, Eigen::MatrixX2d& uv) {
  if (!mesh.has_uv()) return false;
  uv.resize(mesh.V.rows(), 2);
  std::vector<bool> seen(size_t(mesh.V.rows()), false);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(f, c);
      const Eigen::RowVector2d t = mesh.UV.row(mesh.FUV(f, c));
      if (seen[size_t(v)] && (uv.row(v) - t).cwiseAbs().maxCoeff() > 1e-9) return false;
      uv.row(v) = t;
      seen[size_t(v)] = true;
    }
  }
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    if (!seen[size_t(v)]) uv.row(v).setZero();  // isolated vertex
  }
  return true;
}

Eigen::MatrixX4d uv_tangents(const Mesh& mesh) {
  if (!mesh.has_uv() || !mesh.has_normals()) throw InvalidInput("mesh", "tangent frames need UVs and vertex normals", "");
  Eigen::MatrixX3d T = Eigen::MatrixX3d::Zero(mesh.UV.rows(), 3), B = Eigen::MatrixX3d::Zero(mesh.UV.rows(), 3);
  Eigen::VectorXi vertex = Eigen::VectorXi::Constant(mesh.UV.rows(), -1);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const Eigen::Vector3d p0 = mesh.V.row(mesh.F(f, 0)), e1 = mesh.V.row(mesh.F(f, 1)).transpose() - p0,
                          e2 = mesh.V.row(mesh.F(f, 2)).transpose() - p0;
    const Eigen::Vector2d t0 = mesh.UV.row(mesh.FUV(f, 0)), d1 = mesh.UV.row(mesh.FUV(f, 1)).transpose() - t0,
                          d2 = mesh.UV.row(mesh.FUV(f, 2)).transpose() - t0;
    const double det = d1.x() * d2.y() - d2.x() * d1.y();
    const double area = 0.5 * e1.cross(e2).norm();
    if (std::abs(det) < 1e-20 || area == 0) continue;
    // dP/du and dP/dv of the affine map from UV to the triangle, each scaled to unit length times the area.
    const Eigen::Vector3d dpdu = (e1 * d2.y() - e2 * d1.y()) / det, dpdv = (e2 * d1.x() - e1 * d2.x()) / det;
    for (int k = 0; k < 3; ++k) {
      T.row(mesh.FUV(f, k)) += area * dpdu.normalized();
      B.row(mesh.FUV(f, k)) += area * dpdv.normalized();
      vertex(mesh.FUV(f, k)) = mesh.F(f, k);
    }
  }
  Eigen::MatrixX4d frames = Eigen::MatrixX4d::Zero(mesh.UV.rows(), 4);
  for (Eigen::Index i = 0; i < frames.rows(); ++i) {
    if (vertex(i) < 0) continue;
    const Eigen::Vector3d n = mesh.N.row(vertex(i));
    Eigen::Vector3d t = T.row(i).transpose();
    t -= n * n.dot(t);
    if (t.norm() < 1e-12) continue;
    t.normalize();
    frames.row(i) << t.transpose(), n.cross(t).dot(B.row(i).transpose()) < 0 ? -1.0 : 1.0;
  }
  return frames;
}

Eigen::Matrix3f tangent_frame(const Mesh& mesh, const Eigen::MatrixX4d& tangents, int f, const Eigen::Vector3f& b) {
  Eigen::Vector3f n = Eigen::Vector3f::Zero(), t = Eigen::Vector3f::Zero();
  for (int k = 0; k < 3; ++k) {
    n += b[k] * mesh.N.row(mesh.F(f, k)).cast<float>().transpose();
    t += b[k] * tangents.row(mesh.FUV(f, k)).head<3>().cast<float>().transpose();
  }
  n.normalize();
  t = (t - n * n.dot(t)).normalized();
  const float handedness = tangents(mesh.FUV(f, 0), 3) < 0 ? -1.0f : 1.0f;
  Eigen::Matrix3f tbn;
  tbn << t, handedness * n.cross(t), n;
  return tbn;
}

double surface_area(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  double area = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    area += 0.5 * (b - a).cross(c - a).norm();
  }
  return area;
}

}  // namespace bareskin
