// make-dataset's views show one head under rotations we know (we rendered them), so one shape α and expression β are
// fitted to every view's detected landmarks at once, instead of one independent fit per view:
//   min Σ_v Σ_k w_vk |π(R_v (S_k(α, β) + d_k) + t_v) − l_vk|² + λ (|α|² + |β|²)
// with π the fixed camera, l_vk view v's detected landmark k and d_k the detector's convention offset in the model
// frame (0 without a calibration; landmark_offsets below). The head pose is either one (R_v = Q_v R, t_v = Q_v t with
// Q_v the view's known rotation: a rigid rig) or free per view (R_v, t_v started at Q_v: each view keeps its own
// alignment to its image, which the unwrap needs, while the shape is shared). Three views constrain the depth of the
// face that one view leaves to the prior, and the detector's per-view errors partly average out.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "morphable/coefficients.h"
#include "morphable/fit.h"
#include "morphable/model.h"
#include "render/camera.h"

namespace bareskin::texgen {

struct LandmarkViewInput {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // Q_v: the model frame as this view's camera sees it
  Eigen::Matrix<double, 68, 2> landmarks;                   // detected (px)
  Eigen::Matrix<double, 68, 1> weight = Eigen::Matrix<double, 68, 1>::Ones();  // w_vk (0: left out)
};

struct MultiviewLandmarkFit {
  Eigen::VectorXd alpha, beta;
  std::vector<Eigen::Vector3d> rotation, translation;  // per view: R_v (Euler angles, euler_rotation), t_v (mm)
  std::vector<double> rms_px;  // per view, over the landmarks with weight > 0
  Eigen::MatrixXd error_px;    // views × 68: each landmark's reprojection error (px), whatever its weight
  Eigen::MatrixXd weight;      // views × 68: the weights w_vk of the last fit
  int iterations = 0;
};

// A view's silhouette term (fitting/silhouette_fit.h): `vertices` of the model that lie on the view's outline should
// project onto the image's outline: residual sqrt(weight) · sdf(π(R_v S_i + t_v)), sdf the image's signed distance
// to its face outline (px, negative inside; bilinear, clamped at the border).
struct SilhouetteResiduals {
  const std::vector<float>* sdf = nullptr;  // size² row-major
  int size = 0;
  std::vector<int> vertices;
  double weight = 1;  // per vertex
};

// Levenberg–Marquardt on a forward-difference Jacobian (options: components, λ, iterations; options.start is not
// used). `offsets`: d_k (68 × 3 mm, model frame) or nullptr. InvalidInput for a model without 68 landmarks, no views,
// or non-finite landmarks.
MultiviewLandmarkFit fit_landmarks_multiview(const MorphableModel& model, const std::vector<LandmarkViewInput>& views,
                                             const Camera& camera, const LandmarkFitOptions& options,
                                             bool pose_per_view, const Eigen::Matrix<double, 68, 3>* offsets = nullptr);

// The same with per-view silhouette residuals beside the landmarks (one per view, pose_per_view only), started at
// `start` (a fit of the same views and components).
MultiviewLandmarkFit fit_landmarks_multiview(const MorphableModel& model, const std::vector<LandmarkViewInput>& views,
                                             const Camera& camera, const LandmarkFitOptions& options,
                                             const Eigen::Matrix<double, 68, 3>* offsets,
                                             const MultiviewLandmarkFit& start,
                                             const std::vector<SilhouetteResiduals>& silhouettes);

// Per-landmark confidence by iteratively reweighted least squares: after the plain fit, `rounds` refits with each
// landmark's weight times the Cauchy weight 1 / (1 + (e_vk / (c σ))²) of its reprojection error e_vk in the previous
// fit, σ = 1.4826 · median(e) over every view's landmarks (a robust scale) and c = 2.385 (95 % efficiency under
// Gaussian errors). Landmarks the shared shape cannot reach in one view (a detector slip, a jaw point on the far
// side's silhouette) lose their pull; consistent ones keep it. rounds = 0 is fit_landmarks_multiview.
MultiviewLandmarkFit fit_landmarks_multiview_robust(const MorphableModel& model, std::vector<LandmarkViewInput> views,
                                                    const Camera& camera, const LandmarkFitOptions& options,
                                                    bool pose_per_view, const Eigen::Matrix<double, 68, 3>* offsets,
                                                    int rounds);

// The Cauchy weights of fit_landmarks_multiview_robust from a fit's reprojection errors: given(v, k) / (1 + (e_vk /
// (c σ))²) over the landmarks with given weight > 0 (the rest keep theirs).
void reweight_landmarks(const MultiviewLandmarkFit& fit, const std::vector<Eigen::Matrix<double, 68, 1>>& given,
                        std::vector<LandmarkViewInput>& views);

// View v's coefficients: the shared shape and expression with the view's pose (delta and gamma left empty).
Coefficients view_coefficients(const MultiviewLandmarkFit& fit, size_t v);

// Euler angles (rx, ry, rz) of a rotation, the inverse of euler_rotation (R = Rz Ry Rx).
Eigen::Vector3d euler_angles(const Eigen::Matrix3d& R);

// A detector-convention calibration (`landmarks calibrate`: per landmark, the mean offset from the detector's point to
// the true one, in its reference frame) brought into the model frame: the similarity that takes reference + offset
// (the true points) onto the model's landmark vertices over 17–67, applied to −offset, for the inner points 17–67
// (the jaw's 2D points follow each view's silhouette, which no fixed 3D offset describes); rows 0–16 and rows with
// non-finite input are 0. The result is the d_k above.
Eigen::Matrix<double, 68, 3> landmark_offsets(const MorphableModel& model, const Eigen::Matrix<double, 68, 3>& reference,
                                              const Eigen::Matrix<double, 68, 3>& offset);

}  // namespace bareskin::texgen
