#include "scan/multiview.h"

#include <ceres/ceres.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "core/parallel.h"
#include "render/rasterize.h"
#include "template/surface.h"

namespace bareskin {
namespace {

constexpr int kJawEnd = 17;  // iBUG 0..16: the jaw contour

// A view's rasterization: what covers each pixel, and at which depth.
struct ViewRaster {
  RasterOutput raster;
  bool covered(int x, int y) const {
    return x >= 0 && y >= 0 && x < raster.width && y < raster.height && raster.triangle[size_t(y) * raster.width + x] >= 0;
  }
};

// The reprojection residual of one view, in units of the detector's noise σ (AutoDiff).
struct Reprojection {
  Reprojection(const Camera& c, const Eigen::Vector2d& x, double sigma) : camera(c), observed(x), sigma(sigma) {}
  template <typename T>
  bool operator()(const T* const X, T* residual) const {
    T p[3];
    for (int r = 0; r < 3; ++r)
      p[r] = T(camera.R(r, 0)) * X[0] + T(camera.R(r, 1)) * X[1] + T(camera.R(r, 2)) * X[2] + T(camera.t[r]);
    const T depth = -p[2];
    residual[0] = (T(camera.cx) + T(camera.focal) * p[0] / depth - T(observed.x())) / T(sigma);
    residual[1] = (T(camera.cy) - T(camera.focal) * p[1] / depth - T(observed.y())) / T(sigma);
    return true;
  }
  const Camera& camera;
  Eigen::Vector2d observed;
  double sigma;
};

// d(pixel)/d(X) of a pinhole camera at X.
Eigen::Matrix<double, 2, 3> projection_jacobian(const Camera& c, const Eigen::Vector3d& X) {
  const Eigen::Vector3d p = c.R * X + c.t;
  const double d = -p.z();
  Eigen::Matrix<double, 2, 3> dp;
  dp << c.focal / d, 0, c.focal * p.x() / (d * d), 0, -c.focal / d, -c.focal * p.y() / (d * d);
  return dp * c.R;
}

Eigen::Vector3d face_normal(const Mesh& m, int f) {
  const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
  return (b - a).cross(c - a).normalized();
}

Eigen::Vector3d camera_centre(const Camera& c) { return -c.R.transpose() * c.t; }

// The surface point under pixel position (u, v), or the nearest covered pixel within `reach` px; false if none.
bool back_project(const Mesh& scan, const ViewRaster& vr, double u, double v, int reach, Eigen::Vector3d& point,
                  double* moved_px = nullptr) {
  const int px = int(std::floor(u)), py = int(std::floor(v));
  int best = -1;
  double best_d2 = double(reach) * reach + 1;
  for (int dy = -reach; dy <= reach; ++dy)
    for (int dx = -reach; dx <= reach; ++dx)
      if (vr.covered(px + dx, py + dy) && dx * dx + dy * dy < best_d2)
        best = (py + dy) * vr.raster.width + px + dx, best_d2 = dx * dx + dy * dy;
  if (best < 0) return false;
  const Eigen::Vector3i f = scan.F.row(vr.raster.triangle[size_t(best)]);
  const double b1 = vr.raster.bary[2 * size_t(best)], b2 = vr.raster.bary[2 * size_t(best) + 1];
  point = (1 - b1 - b2) * scan.V.row(f[0]) + b1 * scan.V.row(f[1]) + b2 * scan.V.row(f[2]);
  if (moved_px) *moved_px = std::sqrt(best_d2);
  return true;
}

// Whether the detected point lies on the view's outline: uncovered pixels within `radius` of it.
bool on_silhouette(const ViewRaster& vr, double u, double v, double radius) {
  const int px = int(std::floor(u)), py = int(std::floor(v)), r = int(std::ceil(radius));
  bool in = false, out = false;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      if (dx * dx + dy * dy > radius * radius) continue;
      (vr.covered(px + dx, py + dy) ? in : out) = true;
    }
  return in && out;
}

struct Context {
  const Mesh& scan;
  const std::vector<LandmarkView>& views;
  const std::vector<ViewRaster>& rasters;
  const SurfaceLocator& locator;
  const TriangulateOptions& options;
};

// Whether view v sees surface point X: in the image, not behind the rendered surface, not at a grazing angle.
bool sees(const Context& ctx, int v, const Eigen::Vector3d& X, const Eigen::Vector3d& normal) {
  const Camera& cam = ctx.views[v].camera;
  const Eigen::Vector3d q = cam.project(X);
  const int x = int(std::floor(q.x())), y = int(std::floor(q.y()));
  const ViewRaster& vr = ctx.rasters[v];
  if (q.z() <= 0 || !vr.covered(x, y)) return false;
  if (q.z() > vr.raster.depth[size_t(y) * vr.raster.width + x] + ctx.options.depth_tolerance_mm) return false;
  return normal.dot((camera_centre(cam) - X).normalized()) >= ctx.options.min_cos_view;
}

// Robust least squares over the views in `use` from X (Ceres, Cauchy loss on σ-scaled residuals).
Eigen::Vector3d solve_point(const Context& ctx, int i, const std::vector<int>& use, const Eigen::Vector3d& start) {
  double X[3] = {start.x(), start.y(), start.z()};
  ceres::Problem problem;
  for (int v : use) {
    auto* cost = new ceres::AutoDiffCostFunction<Reprojection, 2, 3>(
        new Reprojection(ctx.views[v].camera, ctx.views[v].px.row(i).transpose(), ctx.options.pixel_sigma));
    problem.AddResidualBlock(cost, new ceres::CauchyLoss(1.0), X);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  return {X[0], X[1], X[2]};
}

double residual_px(const LandmarkView& view, int i, const Eigen::Vector3d& X) {
  const Eigen::Vector3d q = view.camera.project(X);
  return (q.head<2>() - view.px.row(i).transpose()).norm();
}

// Landmarks 17–67: fixed surface points, triangulated by reprojection.
TriangulatedLandmark triangulate_surface_point(const Context& ctx, int i, const std::vector<int>& detected) {
  TriangulatedLandmark out;
  const int n = int(ctx.views.size());
  const double sigma = ctx.options.pixel_sigma;
  // Start: the candidate (each view's back-projection) that the most views agree with (truncated cost).
  std::vector<Eigen::Vector3d> candidates;
  for (int v : detected) {
    Eigen::Vector3d p;
    if (back_project(ctx.scan, ctx.rasters[v], ctx.views[v].px(i, 0), ctx.views[v].px(i, 1), 2, p)) candidates.push_back(p);
  }
  if (candidates.empty()) {
    out.reason = "off the scan in every view";
    return out;
  }
  auto visible_views = [&](const Eigen::Vector3d& X, int* occluded) {
    const SurfacePoint s = ctx.locator.locate(X);
    const Eigen::Vector3d normal = face_normal(ctx.scan, s.face);
    std::vector<int> use;
    for (int v : detected) {
      if (sees(ctx, v, s.point, normal))
        use.push_back(v);
      else if (occluded)
        ++*occluded;
    }
    return use;
  };
  Eigen::Vector3d X = candidates[0];
  double best = std::numeric_limits<double>::infinity();
  for (const auto& c : candidates) {
    double cost = 0;
    for (int v : visible_views(c, nullptr)) cost -= 1.0 / (1.0 + std::pow(residual_px(ctx.views[v], i, c) / sigma, 2));
    if (cost < best) best = cost, X = c;
  }
  std::vector<int> use;
  for (int pass = 0; pass <= ctx.options.visibility_passes; ++pass) {
    out.views_rejected_occluded = 0;
    use = visible_views(X, &out.views_rejected_occluded);
    if (use.size() < 2) break;
    X = solve_point(ctx, i, use, X);
  }
  if (use.size() < 2) {
    out.reason = "seen by fewer than two views";
    return out;
  }
  // Inliers (within 3σ after the robust solve) give the final point and its covariance.
  std::vector<int> inliers;
  for (int v : use)
    if (residual_px(ctx.views[v], i, X) <= 3 * sigma) inliers.push_back(v);
  out.views_rejected_outlier = int(use.size() - inliers.size());
  if (inliers.size() < 2) inliers = use, out.views_rejected_outlier = 0;
  X = solve_point(ctx, i, inliers, X);
  Eigen::Matrix3d JtJ = Eigen::Matrix3d::Zero();
  double sum_r2 = 0;
  for (int v : inliers) {
    const auto J = projection_jacobian(ctx.views[v].camera, X);
    JtJ += J.transpose() * J;
    sum_r2 += std::pow(residual_px(ctx.views[v], i, X), 2);
  }
  // Residual variance, with the detector's nominal σ as a prior worth two observations (few views stay sane).
  const int dof = 2 * int(inliers.size()) - 3;
  const double s2 = (sum_r2 + 2 * sigma * sigma) / (dof + 2);
  out.sigma_mm = std::sqrt((s2 * JtJ.inverse()).trace() / 3);
  out.rms_px = std::sqrt(sum_r2 / inliers.size());
  out.views_used = int(inliers.size());
  out.solved = X;
  out.point = ctx.locator.locate(X).point;
  out.valid = true;
  out.reason = "reprojection";
  (void)n;
  return out;
}

// Jaw contour points: the views where the detected point lies on the outline; each gives the surface point its
// silhouette ray grazes; their geometric median (Weiszfeld), snapped.
TriangulatedLandmark triangulate_contour_point(const Context& ctx, int i, const std::vector<int>& detected) {
  TriangulatedLandmark out;
  std::vector<Eigen::Vector3d> candidates;
  std::vector<int> used;
  for (int v : detected) {
    const double u = ctx.views[v].px(i, 0), w = ctx.views[v].px(i, 1);
    Eigen::Vector3d p;
    if (!on_silhouette(ctx.rasters[v], u, w, ctx.options.silhouette_px)) {
      ++out.views_rejected_outlier;
      continue;
    }
    if (back_project(ctx.scan, ctx.rasters[v], u, w, int(std::ceil(ctx.options.silhouette_px)) + 1, p))
      candidates.push_back(p), used.push_back(v);
  }
  if (candidates.empty()) {
    out.reason = "on the outline in no view";
    return out;
  }
  Eigen::Vector3d X = Eigen::Vector3d::Zero();
  for (const auto& c : candidates) X += c;
  X /= double(candidates.size());
  for (int it = 0; it < 50; ++it) {
    Eigen::Vector3d num = Eigen::Vector3d::Zero();
    double den = 0;
    for (const auto& c : candidates) {
      const double w = 1.0 / std::max((c - X).norm(), 1e-6);
      num += w * c, den += w;
    }
    X = num / den;
  }
  double spread2 = 0, rms = 0;
  for (size_t k = 0; k < candidates.size(); ++k) {
    spread2 += (candidates[k] - X).squaredNorm();
    rms += std::pow(residual_px(ctx.views[used[k]], i, X), 2);
  }
  const double n = double(candidates.size());
  // Spread of the per-view points around their median, with a 1 mm floor worth one view (one view gives no spread).
  out.sigma_mm = std::sqrt((spread2 / 3 + 1.0) / n);
  out.rms_px = std::sqrt(rms / n);
  out.views_used = int(candidates.size());
  out.solved = X;
  out.point = ctx.locator.locate(X).point;
  out.valid = true;
  out.reason = "silhouette";
  return out;
}

}  // namespace

Camera look_at_camera(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, int width, int height, double focal) {
  const Eigen::Vector3d z = (eye - target).normalized();  // the camera looks down −z
  Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  if (std::abs(z.dot(up)) > 0.99) up = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d x = up.cross(z).normalized(), y = z.cross(x);
  Camera c;
  c.width = width, c.height = height;
  c.focal = focal;
  c.cx = width / 2.0, c.cy = height / 2.0;
  c.R.row(0) = x, c.R.row(1) = y, c.R.row(2) = z;
  c.t = -c.R * eye;
  return c;
}

std::vector<Camera> landmark_view_ring(int count, int size, const Eigen::Vector3d& target, double distance,
                                       double max_yaw_deg, double max_pitch_deg) {
  if (count < 1) throw InvalidInput("--views", "needs at least one view", "pass a count of 1 or more (e.g. 16)");
  std::vector<Camera> cameras;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int k = 0; k < count; ++k) {
    const double r = k == 0 ? 0 : std::sqrt((k + 0.5) / count), a = k * golden;
    const double yaw = r * std::cos(a) * max_yaw_deg * M_PI / 180, pitch = r * std::sin(a) * max_pitch_deg * M_PI / 180;
    const Eigen::Vector3d dir(std::sin(yaw) * std::cos(pitch), std::sin(pitch), std::cos(yaw) * std::cos(pitch));
    cameras.push_back(look_at_camera(target + distance * dir, target, size, size, 1015.0 * size / 224.0));
  }
  return cameras;
}

void TriangulateOptions::check() const {
  if (!(min_score >= 0 && min_score <= 1))
    throw InvalidInput("the views' score threshold", std::to_string(min_score) + " is not a score in [0, 1]",
                       "use e.g. 0.1 (default)");
  if (!(pixel_sigma >= 0.1 && pixel_sigma <= 100))
    throw InvalidInput("--pixel-sigma", "the detector noise must lie in [0.1, 100] px", "use e.g. 2 (default)");
  if (!(depth_tolerance_mm > 0) || !(silhouette_px > 0))
    throw InvalidInput("triangulation", "the depth tolerance and the silhouette distance must be > 0",
                       "use e.g. 2 mm and 3 px (default)");
  if (!(min_cos_view >= 0 && min_cos_view < 1))
    throw InvalidInput("triangulation", "the grazing-angle cosine must lie in [0, 1)", "use e.g. 0.2 (default)");
  if (visibility_passes < 0 || visibility_passes > 10)
    throw InvalidInput("triangulation", "visibility passes must lie in [0, 10]", "use e.g. 2 (default)");
}

MultiviewLandmarks triangulate_landmarks(const Mesh& scan, const std::vector<LandmarkView>& views,
                                         const TriangulateOptions& options) {
  options.check();
  if (scan.V.rows() == 0 || scan.F.rows() == 0) throw InvalidInput("", "the scan is empty", "check the mesh file");
  if (!scan.V.allFinite()) throw InvalidInput("", "the scan has non-finite vertices", "clean the mesh");
  MultiviewLandmarks result;
  result.views = int(views.size());
  std::vector<int> detected;
  for (int v = 0; v < int(views.size()); ++v) {
    if (views[v].camera.model != Camera::Model::Pinhole)
      throw InvalidInput("", "view " + std::to_string(v) + " is not a pinhole camera", "give pinhole cameras");
    if (views[v].score >= options.min_score && views[v].px.allFinite()) detected.push_back(v);
  }
  result.views_detected = int(detected.size());
  if (detected.size() < 2)
    throw InvalidInput("", "only " + std::to_string(detected.size()) + " of " + std::to_string(views.size()) +
                               " views have a face scoring ≥ " + std::to_string(options.min_score),
                       "check the texture and the cameras, or lower the score threshold");
  std::vector<ViewRaster> rasters(views.size());
  for (int v : detected) rasters[v].raster = rasterize_mesh(scan, views[v].camera);
  const SurfaceLocator locator(scan.V, scan.F);
  const Context ctx{scan, views, rasters, locator, options};
  result.points.resize(68);
  parallel_for(0, 68, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      if (i < kJawEnd && !options.jaw) {
        result.points[i].reason = "jaw contour left out (silhouette-dependent)";
      } else {
        result.points[i] = i < kJawEnd ? triangulate_contour_point(ctx, int(i), detected)
                                       : triangulate_surface_point(ctx, int(i), detected);
      }
      result.points[i].views_rejected_score = int(views.size() - detected.size());
    }
  });
  result.landmarks.units = "mm";
  result.landmarks.points.resize(68, 3);
  for (int i = 0; i < 68; ++i)
    result.landmarks.points.row(i) = result.points[i].valid
                                         ? Eigen::RowVector3d(result.points[i].point.transpose())
                                         : Eigen::RowVector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  return result;
}

double median_landmark_reprojection_px(const LandmarkView& view, const Camera& camera,
                                       const Eigen::Matrix<double, 68, 3>& points) {
  std::vector<double> d;
  for (int i = 17; i < 68; ++i) {
    const Eigen::Vector3d X = points.row(i).transpose();
    if (!X.allFinite() || !view.px.row(i).allFinite()) continue;
    const Eigen::Vector3d q = camera.project(X);
    if (q.z() <= 0) continue;
    d.push_back((q.head<2>() - view.px.row(i).transpose()).norm());
  }
  if (d.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

std::vector<int> inconsistent_views(const std::vector<LandmarkView>& views, const Eigen::Matrix<double, 68, 3>& points,
                                    double min_score, double factor, double floor_px) {
  std::vector<int> used;
  std::vector<double> medians;
  for (size_t v = 0; v < views.size(); ++v) {
    if (views[v].score < min_score) continue;
    const double median = median_landmark_reprojection_px(views[v], views[v].camera, points);
    if (std::isnan(median)) continue;
    used.push_back(int(v));
    medians.push_back(median);
  }
  std::vector<int> out;
  if (medians.size() < 3) return out;  // two views always agree with their own triangulation
  std::vector<double> sorted = medians;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double limit = std::max(factor * sorted[sorted.size() / 2], floor_px);
  for (size_t k = 0; k < used.size(); ++k)
    if (medians[k] > limit) out.push_back(used[k]);
  return out;
}

Eigen::Matrix<double, 68, 3> triangulate_free(const std::vector<LandmarkView>& views, double pixel_sigma,
                                              double min_score) {
  Eigen::Matrix<double, 68, 3> out;
  out.setConstant(std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < 68; ++i) {
    // Midpoint: Σ (I − d dᵀ)(X − c) = 0 over the rays (c: camera centre, d: unit direction).
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    std::vector<int> use;
    for (int v = 0; v < int(views.size()); ++v) {
      const LandmarkView& view = views[v];
      if (view.score < min_score || !view.px.row(i).allFinite()) continue;
      const Camera& c = view.camera;
      const Eigen::Vector3d ray_cam((view.px(i, 0) - c.cx) / c.focal, -(view.px(i, 1) - c.cy) / c.focal, -1);
      const Eigen::Vector3d d = (c.R.transpose() * ray_cam).normalized(), centre = camera_centre(c);
      const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
      A += P, b += P * centre;
      use.push_back(v);
    }
    if (use.size() < 2) continue;
    const Eigen::Vector3d start = A.ldlt().solve(b);
    double X[3] = {start.x(), start.y(), start.z()};
    ceres::Problem problem;
    for (int v : use)
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<Reprojection, 2, 3>(new Reprojection(
                                   views[v].camera, views[v].px.row(i).transpose(), pixel_sigma)),
                               new ceres::CauchyLoss(1.0), X);
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_QR;
    so.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(so, &problem, &summary);
    out.row(i) << X[0], X[1], X[2];
  }
  return out;
}

namespace {

// Similarity (s, R, t) taking `from` onto `to` over the rows valid in both (Umeyama); false with fewer than 4.
bool similarity(const Eigen::Matrix<double, 68, 3>& from, const Eigen::Matrix<double, 68, 3>& to, int first,
                double& s, Eigen::Matrix3d& R, Eigen::Vector3d& t) {
  std::vector<int> rows;
  for (int i = first; i < 68; ++i)
    if (from.row(i).allFinite() && to.row(i).allFinite()) rows.push_back(i);
  if (rows.size() < 4) return false;
  Eigen::Matrix3Xd a(3, rows.size()), b(3, rows.size());
  for (size_t k = 0; k < rows.size(); ++k) a.col(k) = from.row(rows[k]).transpose(), b.col(k) = to.row(rows[k]).transpose();
  const Eigen::Matrix4d T = Eigen::umeyama(a, b, true);
  s = T.block<3, 3>(0, 0).determinant() > 0 ? std::cbrt(T.block<3, 3>(0, 0).determinant()) : 1;
  R = T.block<3, 3>(0, 0) / s;
  t = T.block<3, 1>(0, 3);
  return true;
}

Eigen::Matrix<double, 68, 3> as_matrix(const Landmarks& l) {
  if (l.points.rows() != 68 || l.points.cols() != 3) throw InvalidInput("", "3D landmarks need 68 × 3 points", "");
  return l.points;
}

// Per-point mean of the finite rows of `values` (NaN where none is).
Eigen::Matrix<double, 68, 3> mean_rows(const std::vector<Eigen::Matrix<double, 68, 3>>& values, int skip = -1) {
  Eigen::Matrix<double, 68, 3> m;
  for (int i = 0; i < 68; ++i) {
    Eigen::RowVector3d sum = Eigen::RowVector3d::Zero();
    int n = 0;
    for (size_t j = 0; j < values.size(); ++j)
      if (int(j) != skip && values[j].row(i).allFinite()) sum += values[j].row(i), ++n;
    m.row(i) = n ? Eigen::RowVector3d(sum / n) : Eigen::RowVector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return m;
}

}  // namespace

LandmarkCalibration calibrate_landmarks(const std::vector<MultiviewLandmarks>& detected,
                                        const std::vector<Landmarks>& truth) {
  const size_t n = detected.size();
  if (n < 2 || truth.size() != n)
    throw InvalidInput("", "a calibration needs two or more scans with known landmarks", "give more scans");
  std::vector<Eigen::Matrix<double, 68, 3>> D(n), T(n);
  for (size_t j = 0; j < n; ++j) {
    D[j] = as_matrix(detected[j].landmarks), T[j] = as_matrix(truth[j]);
    int finite = 0;
    for (int i = 17; i < 68; ++i) finite += D[j].row(i).allFinite();
    if (finite < 20)
      throw InvalidInput("", "scan " + std::to_string(j) + " has fewer than 20 triangulated points in 17-67",
                         "check its texture and detections");
  }
  // Generalised Procrustes of the detected points (17–67), three rounds.
  LandmarkCalibration c;
  c.scans = int(n), c.views = detected[0].views;
  std::vector<double> scale(n);
  std::vector<Eigen::Matrix3d> rot(n);
  std::vector<Eigen::Vector3d> shift(n);
  c.reference = D[0];
  for (int round = 0; round < 3; ++round) {
    std::vector<Eigen::Matrix<double, 68, 3>> aligned(n);
    for (size_t j = 0; j < n; ++j) {
      if (!similarity(D[j], c.reference, 17, scale[j], rot[j], shift[j]))
        throw InvalidInput("", "scan " + std::to_string(j) + " shares too few points with the others", "");
      aligned[j] = ((scale[j] * (rot[j] * D[j].transpose())).colwise() + shift[j]).transpose();
    }
    c.reference = mean_rows(aligned);
  }
  std::vector<Eigen::Matrix<double, 68, 3>> off(n), shape(n);
  for (size_t j = 0; j < n; ++j) {
    off[j] = (scale[j] * (rot[j] * (T[j] - D[j]).transpose())).transpose();
    shape[j] = ((scale[j] * (rot[j] * T[j].transpose())).colwise() + shift[j]).transpose();
  }
  c.offset = mean_rows(off), c.shape = mean_rows(shape);
  // Leave-one-out spread of both predictions.
  Eigen::Matrix<double, 68, 1> sd = Eigen::Matrix<double, 68, 1>::Zero(), ss = sd, nd = sd, ns = sd;
  for (size_t k = 0; k < n; ++k) {
    const auto o = mean_rows(off, int(k)), sh = mean_rows(shape, int(k));
    for (int i = 0; i < 68; ++i) {
      const Eigen::Vector3d truth_i = T[k].row(i).transpose();
      if (D[k].row(i).allFinite() && o.row(i).allFinite()) {
        const Eigen::Vector3d p = D[k].row(i).transpose() + rot[k].transpose() * o.row(i).transpose() / scale[k];
        sd[i] += (p - truth_i).squaredNorm(), ++nd[i];
      }
      if (sh.row(i).allFinite()) {
        const Eigen::Vector3d p = rot[k].transpose() * (sh.row(i).transpose() - shift[k]) / scale[k];
        ss[i] += (p - truth_i).squaredNorm(), ++ns[i];
      }
    }
  }
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < 68; ++i) {
    c.spread_detected_mm[i] = nd[i] ? std::sqrt(sd[i] / nd[i]) : inf;
    c.spread_shape_mm[i] = ns[i] ? std::sqrt(ss[i] / ns[i]) : inf;
  }
  return c;
}

void apply_calibration(const Mesh& scan, const LandmarkCalibration& c, MultiviewLandmarks& result) {
  Eigen::Matrix<double, 68, 3> D = as_matrix(result.landmarks);
  double s;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  if (!similarity(c.reference, D, 17, s, R, t))
    throw InvalidInput("", "too few landmarks were triangulated to apply the calibration", "check the detections");
  const SurfaceLocator locator(scan.V, scan.F);
  for (int i = 0; i < 68; ++i) {
    TriangulatedLandmark& p = result.points[size_t(i)];
    const bool have = p.valid && std::isfinite(c.spread_detected_mm[i]) && c.offset.row(i).allFinite();
    const bool by_shape = (!have || c.spread_shape_mm[i] < c.spread_detected_mm[i]) && std::isfinite(c.spread_shape_mm[i]);
    if (!have && !by_shape) continue;
    const Eigen::Vector3d X = by_shape ? Eigen::Vector3d(s * R * c.shape.row(i).transpose() + t)
                                       : Eigen::Vector3d(p.point + s * R * c.offset.row(i).transpose());
    const double spread = by_shape ? c.spread_shape_mm[i] : c.spread_detected_mm[i];
    p.sigma_mm = std::sqrt((by_shape || p.sigma_mm < 0 ? 0 : p.sigma_mm * p.sigma_mm) + spread * spread);
    p.point = locator.locate(X).point;
    if (by_shape) p.reason = "shape (calibration)", p.views_used = 0;
    p.valid = p.calibrated = true;
    result.landmarks.points.row(i) = p.point.transpose();
  }
}

std::string landmark_calibration_json(const LandmarkCalibration& c) {
  auto rows = [](const Eigen::Matrix<double, 68, 3>& m) {
    auto a = nlohmann::json::array();
    for (int i = 0; i < 68; ++i)
      a.push_back(m.row(i).allFinite() ? nlohmann::json{m(i, 0), m(i, 1), m(i, 2)} : nlohmann::json(nullptr));
    return a;
  };
  auto column = [](const Eigen::Matrix<double, 68, 1>& v) {
    auto a = nlohmann::json::array();
    for (int i = 0; i < 68; ++i) a.push_back(std::isfinite(v[i]) ? nlohmann::json(v[i]) : nlohmann::json(nullptr));
    return a;
  };
  const nlohmann::json doc = {{"format", "bareskin landmark calibration 1"}, {"scheme", "ibug68"}, {"units", "mm"},
                              {"scans", c.scans}, {"views", c.views}, {"reference", rows(c.reference)},
                              {"offset", rows(c.offset)}, {"shape", rows(c.shape)},
                              {"spread_detected_mm", column(c.spread_detected_mm)},
                              {"spread_shape_mm", column(c.spread_shape_mm)}};
  return doc.dump(1) + "\n";
}

LandmarkCalibration read_landmark_calibration(const std::string& path) {
  nlohmann::json doc;
  try {
    doc = nlohmann::json::parse(read_file(path));
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(path, std::string("is not JSON (") + e.what() + ")", "write it with `landmarks calibrate`");
  }
  if (doc.value("format", "") != "bareskin landmark calibration 1")
    throw InvalidInput(path, "is not a landmark calibration", "write it with `landmarks calibrate`");
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  LandmarkCalibration c;
  try {
    auto rows = [&](const char* key, Eigen::Matrix<double, 68, 3>& m) {
      const auto& a = doc.at(key);
      if (!a.is_array() || a.size() != 68) throw InvalidInput(path, std::string("'") + key + "' needs 68 rows", "");
      for (int i = 0; i < 68; ++i)
        for (int k = 0; k < 3; ++k) m(i, k) = a[size_t(i)].is_null() ? nan : a[size_t(i)].at(size_t(k)).get<double>();
    };
    auto column = [&](const char* key, Eigen::Matrix<double, 68, 1>& v) {
      const auto& a = doc.at(key);
      if (!a.is_array() || a.size() != 68) throw InvalidInput(path, std::string("'") + key + "' needs 68 values", "");
      for (int i = 0; i < 68; ++i) v[i] = a[size_t(i)].is_null() ? inf : a[size_t(i)].get<double>();
    };
    rows("reference", c.reference), rows("offset", c.offset), rows("shape", c.shape);
    column("spread_detected_mm", c.spread_detected_mm), column("spread_shape_mm", c.spread_shape_mm);
    c.scans = doc.at("scans").get<int>(), c.views = doc.value("views", 0);
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(path, std::string("has a malformed field (") + e.what() + ")", "write it with `landmarks calibrate`");
  }
  return c;
}

std::string multiview_landmarks_json(const MultiviewLandmarks& result) {
  nlohmann::json doc = {{"scheme", "ibug68"}, {"units", "mm"}, {"views", result.views},
                        {"views_detected", result.views_detected}};
  auto points = nlohmann::json::array(), detail = nlohmann::json::array();
  for (const auto& p : result.points) {
    if (p.valid)
      points.push_back({p.point.x(), p.point.y(), p.point.z()});
    else
      points.push_back(nullptr);
    detail.push_back({{"sigma_mm", p.sigma_mm},
                      {"rms_px", p.rms_px},
                      {"views", p.views_used},
                      {"occluded", p.views_rejected_occluded},
                      {"outliers", p.views_rejected_outlier},
                      {"method", p.valid ? p.reason : "none"},
                      {"calibrated", p.calibrated},
                      {"reason", p.valid ? "" : p.reason}});
  }
  doc["points"] = points;
  doc["detail"] = detail;
  return doc.dump(1) + "\n";
}

}  // namespace bareskin
