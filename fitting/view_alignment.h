// Photometric consistency of make-dataset's views: every view's unwrap should show the same skin in the overlap, yet
// each view's pose follows its own detected landmarks, which scatter by 2–3 % of the image, so the views' features
// land a few texels apart in the UV and the merge ghosts them. Each view's head pose (rotation, translation; the
// fitted shape is kept) is moved so that its unwrap agrees with the others':
//   min over (R_v, t_v)  Σ_i w_vi |I_v(π(R_v p_i + t_v)) − m_¬v(i)|²
// with p_i the fitted shape's point at UV texel i, I_v the view's image (the one that is unwrapped), m_¬v the
// confidence-weighted merge of the other views' unwraps under their current poses, and w_vi = c_vi · c_¬v,i the
// views' view-angle confidences (visibility fixed at the landmark poses). Every view is aligned to the others at once
// (Jacobi rounds), so no view is the reference and the views' mean placement stays that of their landmarks.
// Levenberg–Marquardt over the 6 pose parameters, coarse to fine (UV and image at size/2, then size).
// With `shape`, the shared identity α joins the free views' poses in one problem over the views' pairwise
// disagreement (a wrong shape, not only a wrong pose, makes the views disagree; the model's few components and the
// landmark term keep it determined).
#pragma once
#include <vector>

#include "core/image.h"
#include "morphable/coefficients.h"
#include "morphable/model.h"
#include "render/camera.h"
#include "fitting/multiview_fit.h"

namespace bareskin::texgen {

struct ViewAlignmentOptions {
  int rounds = 0;        // Jacobi rounds (0: off)
  int size = 256;        // UV and image size of the finest level
  int iterations = 8;    // Levenberg–Marquardt steps per level
  double sharpness = 4;  // the merge of the other views: confidence^sharpness
  // The views' landmarks hold each pose near where they put it: their reprojection error (px at the render size, over
  // the landmarks' weights) counts beside the disagreement, as landmark_weight × mean |error / 10 px|² against
  // mean w |Δcolour / 0.05|²; 0: poses from the colours alone (they compensate a wrong shape and drift).
  double landmark_weight = 0;
  bool fix_first = true; // the first view (the front) keeps its landmark pose and the others are aligned to it;
                         // false: every view moves (the views' common zoom is then free and drifts)
  // The shared shape too: identity α (shared by the views, taken from the first view) with every free view's pose in
  // one Levenberg–Marquardt problem over the views' pairwise disagreement Σ_{u<v} Σ_i c_ui c_vi |I_u − I_v|², the
  // landmark term above and shape_prior · |α|² (α in standard deviations); `rounds` passes over the levels.
  bool shape = false;
  double shape_prior = 1;
  void check() const;    // InvalidInput when out of range
};

struct ViewAlignment {
  std::vector<Coefficients> views;          // the input coefficients with the aligned poses
  std::vector<double> rms_before, rms_after;  // per view: weighted RMS disagreement with the others (linear RGB)
};

// `views`: each view's coefficients (shape, expression and pose as the unwrap uses them); `images`: each view's image
// (linear or sRGB, camera.width² — the unwrapped one); `camera`: the render's camera. InvalidInput when the counts
// or sizes differ. Fewer than two views: returned unchanged.
// `landmarks`: per view the detected landmarks and their weights (the landmark fit's), used when
// options.landmark_weight > 0; `offsets`: the detector's convention in the model frame (or nullptr).
ViewAlignment align_views_photometric(const MorphableModel& model, const std::vector<Coefficients>& views,
                                      const std::vector<const Image*>& images, const Camera& camera,
                                      const ViewAlignmentOptions& options,
                                      const std::vector<LandmarkViewInput>& landmarks = {},
                                      const Eigen::Matrix<double, 68, 3>* offsets = nullptr);

}  // namespace bareskin::texgen
