// Multi-view landmark triangulation (docs/pipeline.md, "Multi-view scan landmarks"). A scan is seen by N cameras of
// known intrinsics and extrinsics (virtual cameras around a render of the scan, or a rig's cameras recovered by
// COLMAP); a 2D detector gives the 68 iBUG points in each view. Each landmark is then the 3D point whose projections
// best agree with the views that see it:
//   X* = argmin_X Σ_v ρ(‖π_v(X) − x_v‖² / σ²)        (Cauchy ρ, σ in pixels, solved with Ceres)
// where a view takes part only if its detector score is high enough, the point is not hidden by the surface there
// (depth test against the rasterized scan), and the surface is not seen at a grazing angle. The solution is snapped
// onto the scan (closest point). Its uncertainty is the Gauss–Newton covariance (JᵀJ)⁻¹ at the solution scaled by the
// residual variance, reported as the RMS of its axes (σ_3D, mm).
//
// Jaw contour points (0–16) lie on the face's outline in a 2D detector's training data, and the outline moves over
// the surface with the view: their rays do not meet in one surface point. They are triangulated only from the views
// in which the detected point lies on the rendered silhouette of the face, and each such view constrains the point by
// its silhouette ray (the surface point nearest to it), not by a reprojection.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/landmarks.h"
#include "core/mesh.h"
#include "render/camera.h"

namespace bareskin {

// One view: its camera, the 68 detected points (pixels, origin at the top-left corner) and the detector's score.
// A view without a detection has score 0 and is not used.
struct LandmarkView {
  Camera camera;
  Eigen::Matrix<double, 68, 2> px = Eigen::Matrix<double, 68, 2>::Zero();
  double score = 0;
};

// `count` pinhole cameras looking at `target` from `distance` mm, spread over a cap in front of the face (+z): a
// sunflower pattern in (yaw, pitch) within ±max_yaw_deg, ±max_pitch_deg, the first view straight in front. Image
// size² px, focal as render/camera.h's view_camera. InvalidInput for count < 1.
std::vector<Camera> landmark_view_ring(int count, int size, const Eigen::Vector3d& target, double distance = 1000,
                                       double max_yaw_deg = 40, double max_pitch_deg = 25);

// A pinhole camera at `eye` looking at `target` (image up ≈ +y): the convention of render/camera.h.
Camera look_at_camera(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, int width, int height, double focal);

struct TriangulateOptions {
  double min_score = 0.1;         // views whose detector scored below take no part (renders score 0.2–0.9)
  double pixel_sigma = 2.0;       // expected detector noise (px at the view's resolution); the Cauchy loss's scale
  double depth_tolerance_mm = 2;  // a point farther than this behind the rendered surface is occluded in that view
  double min_cos_view = 0.2;      // surface normal · direction to the camera below this: grazing, not used
  double silhouette_px = 3;       // jaw points: on the outline when within this of an uncovered pixel
  int visibility_passes = 2;      // re-solve after the depth test with the new point
  bool jaw = true;                // triangulate 0–16 from silhouette views (false: leave them out)
  void check() const;             // InvalidInput naming the option
};

struct TriangulatedLandmark {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  // on the scan (snapped), mm
  Eigen::Vector3d solved = Eigen::Vector3d::Zero(); // the least-squares point before snapping
  double sigma_mm = 0;         // RMS of the covariance's axes (−1: not estimated, e.g. one view)
  double rms_px = 0;           // RMS reprojection residual over the views used
  int views_used = 0;
  int views_rejected_occluded = 0, views_rejected_score = 0, views_rejected_outlier = 0;
  bool valid = false;
  std::string reason;          // why a point is not valid, or how it was found ("silhouette", "reprojection")
  bool calibrated = false;     // moved by a LandmarkCalibration (then sigma_mm includes its spread)
};

struct MultiviewLandmarks {
  std::vector<TriangulatedLandmark> points;  // 68
  Landmarks landmarks;                       // 68 × 3 mm (invalid ones: NaN rows)
  int views = 0, views_detected = 0;
};

// Triangulates the 68 landmarks of `views` on `scan` (mm). InvalidInput when fewer than two views have detections,
// the scan is empty, or a camera is not a pinhole camera.
MultiviewLandmarks triangulate_landmarks(const Mesh& scan, const std::vector<LandmarkView>& views,
                                         const TriangulateOptions& options = {});

// Landmarks triangulated without a mesh (no occlusion test; e.g. in a COLMAP model's frame before it is aligned):
// the rays' least-squares point per landmark, refined robustly in Ceres; NaN rows where fewer than two views with a
// score ≥ min_score see it.
Eigen::Matrix<double, 68, 3> triangulate_free(const std::vector<LandmarkView>& views, double pixel_sigma = 2,
                                              double min_score = 0.1);

// The median over landmarks 17–67 of the distance (px) between `view`'s detections and the projection of `points`
// through `camera` (landmarks not finite, or behind the camera, left out); NaN when none is left.
double median_landmark_reprojection_px(const LandmarkView& view, const Camera& camera,
                                       const Eigen::Matrix<double, 68, 3>& points);

// Views whose camera disagrees with the others: per view (detected, score ≥ min_score), the median over landmarks
// 17–67 of the distance between its detected pixel and the projection of `points` (triangulated from all views); a
// view is inconsistent when that median exceeds max(factor × the median of the views' medians, floor_px). A camera
// that structure from motion placed wrongly (a repetitive backdrop can do that) shows as one such view: its face is
// detected, but the points everyone else agrees on project far from it. Returns the views' indices, ascending.
std::vector<int> inconsistent_views(const std::vector<LandmarkView>& views, const Eigen::Matrix<double, 68, 3>& points,
                                    double min_score = 0.1, double factor = 5, double floor_px = 10);

// A 2D detector's landmarks follow its training annotations (300-W on photos), which differ from a template's own
// landmark vertices by a few mm per point (brows higher, mouth corners wider, inner lips on the visible lip line). A
// calibration learns that convention from scans with known landmarks (hand-placed, or `scan synth`'s truth):
//   reference  mean of the detected points after similarity alignment (generalised Procrustes on 17–67);
//   offset_i   mean of (truth_i − detected_i) in the reference frame;
//   shape_i    mean true point in the reference frame (predicts points that were not triangulated);
//   spread_i   RMS of the corrected point's error over the calibration scans (leave-one-out), per method.
// Applied to a new scan: (s, R, t) aligns the reference to the scan's detected 17–67, then
// X_i = detected_i + s R offset_i (or s R shape_i + t where that predicted better in calibration or the point is
// missing), snapped to the surface; σ_i = sqrt(σ_triangulation² + spread_i²).
struct LandmarkCalibration {
  Eigen::Matrix<double, 68, 3> reference, offset, shape;
  Eigen::Matrix<double, 68, 1> spread_detected_mm, spread_shape_mm;
  int scans = 0, views = 0;
};

// InvalidInput when fewer than two scans are given or a scan has fewer than 20 valid points in 17–67.
LandmarkCalibration calibrate_landmarks(const std::vector<MultiviewLandmarks>& detected,
                                        const std::vector<Landmarks>& truth);
void apply_calibration(const Mesh& scan, const LandmarkCalibration& calibration, MultiviewLandmarks& result);
std::string landmark_calibration_json(const LandmarkCalibration& calibration);
LandmarkCalibration read_landmark_calibration(const std::string& path);  // InvalidInput/IoError naming the file

// The JSON that `landmarks scan --views` writes: the landmark file's fields plus per-point "sigma_mm", "views",
// "rms_px", "method" and the view count (docs/file_formats.md).
std::string multiview_landmarks_json(const MultiviewLandmarks& result);

}  // namespace bareskin
