#include "template/surface.h"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/locate.h>
#include <CGAL/Polygon_mesh_processing/remesh.h>
#include <CGAL/Surface_mesh.h>
#include <spdlog/spdlog.h>

#include <cmath>

#include "core/mesh.h"

namespace bareskin {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>>>;

SurfaceMesh to_cgal(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  SurfaceMesh sm;
  std::vector<SurfaceMesh::Vertex_index> vi;
  for (Eigen::Index i = 0; i < V.rows(); ++i) vi.push_back(sm.add_vertex(Point(V(i, 0), V(i, 1), V(i, 2))));
  for (Eigen::Index f = 0; f < F.rows(); ++f) sm.add_face(vi[F(f, 0)], vi[F(f, 1)], vi[F(f, 2)]);
  return sm;
}

void from_cgal(SurfaceMesh& sm, Eigen::MatrixX3d& V, Eigen::MatrixX3i& F) {
  sm.collect_garbage();
  V.resize(sm.number_of_vertices(), 3);
  for (auto v : sm.vertices()) V.row(v.idx()) << sm.point(v).x(), sm.point(v).y(), sm.point(v).z();
  F.resize(sm.number_of_faces(), 3);
  for (auto f : sm.faces()) {
    // Corners in the order source(h), target(h), target(next(h)), the order locate() gives barycentrics in.
    const auto h = sm.halfedge(f);
    F.row(f.idx()) << int(sm.source(h).idx()), int(sm.target(h).idx()), int(sm.target(sm.next(h)).idx());
  }
}

}  // namespace

void isotropic_remesh(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int target_vertices, int iterations,
                      Eigen::MatrixX3d& V_out, Eigen::MatrixX3i& F_out) {
  // An even mesh has about 2 faces per vertex, each of area sqrt(3)/4 e^2.
  double edge = std::sqrt(4.0 * surface_area(V, F) / (std::sqrt(3.0) * 2.0 * target_vertices));
  const SurfaceMesh reference = to_cgal(V, F);
  SurfaceMesh result;
  for (int pass = 0; pass < 2; ++pass) {
    result = reference;
    PMP::isotropic_remeshing(faces(result), edge, result,
                             PMP::parameters::number_of_iterations(iterations).protect_constraints(false));
    const double ratio = double(result.number_of_vertices()) / target_vertices;
    spdlog::debug("remesh pass {}: edge {:.4f} mm -> {} vertices", pass, edge, result.number_of_vertices());
    if (std::abs(ratio - 1.0) < 0.02) break;
    edge *= std::sqrt(ratio);
  }
  from_cgal(result, V_out, F_out);
}

struct SurfaceLocator::Impl {
  SurfaceMesh mesh;
  Tree tree;
  Eigen::MatrixX3i F;
};

SurfaceLocator::SurfaceLocator(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) : impl_(std::make_unique<Impl>()) {
  impl_->mesh = to_cgal(V, F);
  impl_->F = F;
  PMP::build_AABB_tree(impl_->mesh, impl_->tree);
  impl_->tree.accelerate_distance_queries();
  // The first query builds the search structure lazily; make it here so concurrent queries only read.
  impl_->tree.closest_point(Point(V(0, 0), V(0, 1), V(0, 2)));
}

SurfaceLocator::~SurfaceLocator() = default;

SurfacePoint SurfaceLocator::locate(const Eigen::Vector3d& q) const {
  const auto loc = PMP::locate_with_AABB_tree(Point(q.x(), q.y(), q.z()), impl_->tree, impl_->mesh);
  SurfacePoint out;
  out.face = int(loc.first.idx());
  // locate()'s weights follow source(h), target(h), target(next(h)) of the face's halfedge h; map them to the
  // corner order of the F this locator was built from.
  const SurfaceMesh& sm = impl_->mesh;
  const auto h = sm.halfedge(loc.first);
  const int corner[3] = {int(sm.source(h).idx()), int(sm.target(h).idx()), int(sm.target(sm.next(h)).idx())};
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) {
      if (impl_->F(out.face, j) == corner[k]) out.barycentric[j] = loc.second[k];
    }
  }
  const Point p = PMP::construct_point(loc, impl_->mesh);
  out.point << p.x(), p.y(), p.z();
  return out;
}

}  // namespace bareskin
