// Surface operations on CGAL shared by the template builder and the scan synthesiser: isotropic remeshing to a vertex
// budget, and locating points on a triangle mesh (closest point, face, barycentric coordinates).
#pragma once
#include <Eigen/Core>
#include <memory>

namespace bareskin {

// Remeshes (V, F) to an even edge length that gives about `target_vertices` vertices (one corrective pass when the
// first lands more than 2% off). `iterations` isotropic remeshing passes each time.
void isotropic_remesh(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int target_vertices, int iterations,
                      Eigen::MatrixX3d& V_out, Eigen::MatrixX3i& F_out);

struct SurfacePoint {
  int face = -1;
  Eigen::Vector3d barycentric;  // weights of F(face, 0..2)
  Eigen::Vector3d point;        // the closest point on the surface
};

// Closest-point queries on a fixed triangle mesh (AABB tree); thread-safe after construction.
class SurfaceLocator {
 public:
  SurfaceLocator(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);
  ~SurfaceLocator();
  SurfacePoint locate(const Eigen::Vector3d& query) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace bareskin
