// Fitting the morphable model to 2D landmarks (the landmark term of `mm-fit`; BareSkinNet's L_land with L_reg):
// pose (rotation as Rz·Ry·Rx angles, translation in mm), the first identity and expression coefficients α and β,
// minimising Σ |π(R S_k(α, β) + t) − l_k|² + λ (|α|² + |β|²) over the 68 landmarks, with π a fixed pinhole camera (the `render --model`
// camera). Levenberg–Marquardt on a forward-difference Jacobian; α and β are standardised, so λ is in px² per unit.
#pragma once
#include <Eigen/Core>

#include "morphable/model.h"
#include "render/camera.h"

namespace bareskin {

struct LandmarkFitOptions {
  int shape_components = 40;       // α fitted (at most the model's)
  int expression_components = 20;  // β fitted (at most the model's)
  double regularisation = 1.0;  // λ
  int iterations = 50;
  void check() const;
};

struct LandmarkFit {
  Eigen::VectorXd alpha, beta;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero(), translation = Eigen::Vector3d::Zero();
  double rms_px = 0;  // landmark reprojection error
  int iterations = 0;
};

// Pose applied to model points: R(rotation) p + translation, R = Rz(rz) Ry(ry) Rx(rx).
Eigen::Matrix3d euler_rotation(const Eigen::Vector3d& angles);

// landmarks_px: 68 x 2 (pixels, origin top-left). InvalidInput for a model without 68 landmarks or non-finite input.
LandmarkFit fit_landmarks(const MorphableModel& model, const Eigen::MatrixX2d& landmarks_px, const Camera& camera,
                          const LandmarkFitOptions& options = {});

}  // namespace bareskin
