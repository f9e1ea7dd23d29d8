// make-dataset's renders show the scan on black from cameras we know, so each view's outline of the face is exact in
// the image; face-api's landmarks scatter by 2–3 % of the image. The silhouette term pulls the fitted shape's own
// outline in each view (the template's open border and the occluding contour: jaw, cheeks) onto the image's outline,
// beside the landmarks (multiview_fit.h):
//   Σ_v Σ_i w_s · sdf_v(π(R_v S_i(α, β) + t_v))²,  i over the outline vertices of view v under the current fit,
// sdf_v the signed distance (px) to the image's outline. The outline vertices are chosen again after each round
// (like ICP's correspondences), the fit starting where the last round ended.
#pragma once
#include <cstdint>
#include <vector>

#include "core/image.h"
#include "morphable/coefficients.h"
#include "morphable/model.h"
#include "render/camera.h"
#include "fitting/multiview_fit.h"

namespace bareskin::texgen {

// The face's region in a render on black: every pixel not joined to the image border through black pixels (holes of
// dark skin inside the face stay in). size² row-major, 1 inside. The render must be square.
std::vector<uint8_t> face_silhouette(const Image& render);

// Signed distance (px) of each pixel centre to the outline of a size² mask: the exact Euclidean distance to the
// nearest pixel of the other side, minus half a pixel, negative inside (so 0 on the boundary between pixels).
std::vector<float> signed_distance(const std::vector<uint8_t>& mask, int size);

// The model's vertices on the outline of posed_mesh(model, c) as `camera` sees it (size² image): ends of border edges
// and of edges between a front- and a back-facing triangle whose projection has background of the mesh's own raster
// within 2 px. Every k-th of them (in vertex order) when there are more than max_points.
std::vector<int> outline_vertices(const MorphableModel& model, const Coefficients& c, const Camera& camera,
                                  int max_points);

struct SilhouetteFitOptions {
  int rounds = 0;            // 0: off
  double weight = 1;         // all of a view's outline points together weigh `weight` × its 68 landmarks
  int max_points = 300;      // outline vertices per view
  void check() const;        // InvalidInput when out of range
};

// Refines a shared-shape multi-view landmark fit (pose per view) with the views' silhouettes: `rounds` times, the
// outline vertices under the current fit, then a joint fit of landmarks and silhouettes from the current fit. With
// `robust`, each round first reweights the landmarks (reweight_landmarks, from the views' given weights) by the current
// fit's errors, so a view's slipped landmarks lose their pull once the outline has moved its pose.
// `renders`: the views' images (the camera's size²), in view order.
MultiviewLandmarkFit refine_with_silhouettes(const MorphableModel& model, std::vector<LandmarkViewInput> views,
                                             const std::vector<const Image*>& renders, const Camera& camera,
                                             const LandmarkFitOptions& options,
                                             const Eigen::Matrix<double, 68, 3>* offsets, MultiviewLandmarkFit fit,
                                             const SilhouetteFitOptions& silhouette, bool robust);

}  // namespace bareskin::texgen
