// One texture-inference training sample (paper §5): a registered subject rendered with its diffuse from several
// yaw angles, the 3DMM fitted to each render as inference would (detected landmarks, then the landmark and photometric
// fits of `mm-fit`), each render unwrapped into the template UV through its own fit, the views merged by confidence,
// and the fitted 3DMM's appearance, normals and positions baked into the same UV. `make_dataset.h` turns these into
// shards; docs/datasets.md describes the method.
#pragma once
#include <Eigen/Core>
#include <array>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "morphable/coefficients.h"
#include "morphable/fit.h"
#include "morphable/model.h"
#include "render/camera.h"
#include "fitting/silhouette_fit.h"
#include "fitting/view_alignment.h"
#include "fitting/view_calibration.h"
#include "uvtools/unwarp.h"

namespace bareskin::texgen {

using Landmarks68 = Eigen::Matrix<double, 68, 2>;

// The 68 iBUG landmarks (px, origin at the top-left corner of the top-left pixel) of the best face in an sRGB
// image, or nothing when no face is found. The command passes face-api's networks in; the library links no Torch.
using FaceLandmarkDetector = std::function<std::optional<Landmarks68>(const Image& srgb)>;

struct ViewSpec {
  std::string name;    // front, left, right
  double yaw_deg = 0;  // the head's turn: positive shows the camera the face's left side (+x)
};

struct TextureSampleOptions {
  std::vector<ViewSpec> views = {{"front", 0}, {"left", 30}, {"right", -30}};
  int render_size = 1024;  // the renders (and the unwrap's source); a multiple of fit_size
  int fit_size = 256;      // the photometric fit's image (the canonical 256² face of inference)
  int input_res = 1024;    // UV size of the inputs
  double merge_sharpness = 4;  // views are weighted by confidence^sharpness
  bool unwrap_lit = false;     // unwrap the lit render instead of the diffuse-only one
  // Texels whose sample in the render touches the background (outside the face the render shows; a fitted outline
  // wider than the face samples black there) count as unseen (UnwarpOptions::inside: sampled in the unwrap's own pass).
  bool drop_background = true;
  // The landmark fit over the views (fitting/multiview_fit.h): "shared-shape" (one shape and expression for all
  // views, a pose per view), "rigid" (one shape and one head pose, the views' known rotations between them) or
  // "per-view" (an independent fit per view).
  std::string landmark_fit_mode = "shared-shape";
  // The detector's landmark convention in the model frame (landmark_offsets of a `landmarks calibrate` file), added
  // to the model's landmark vertices in the landmark fits; empty: none.
  std::optional<Eigen::Matrix<double, 68, 3>> landmark_offsets;
  // The detector's per-view 2D bias (fitting/view_calibration.h: learned on training subjects with the same
  // landmark_offsets), subtracted from each view's detected landmarks before the fits; empty: none.
  std::optional<ViewCalibration> view_calibration;
  std::string view_calibration_source;  // its file, for error messages
  // Reweighted refits of the landmark fit (fit_landmarks_multiview_robust): landmarks far from where the shared shape
  // puts them lose weight (multi-view modes, and per-view with a calibration).
  int landmark_robust_rounds = 2;
  // Rounds of the silhouette term on the shared-shape fit (fitting/silhouette_fit.h): each view's fitted outline onto
  // the render's outline of the face on black; 0: off.
  SilhouetteFitOptions silhouette;
  // Photometric consistency between the views' unwraps (fitting/view_alignment.h): the shared shape and the side
  // views' poses moved so that the views' unwraps agree, the landmarks holding them (weight 10); rounds 1 (the
  // default): one pass at 64² and 128² (its gain and cost per subject: bench/BENCHMARKS.md, make-dataset); 0: off. Per-view landmark fits keep their own shapes (poses only).
  ViewAlignmentOptions align = [] {
    ViewAlignmentOptions a;
    a.rounds = 1;
    a.size = 128;
    a.landmark_weight = 10;
    a.shape = true;
    return a;
  }();
  LandmarkFitOptions landmark_fit;
  PhotometricFitOptions photometric;
  void check() const;  // InvalidInput when out of range
};

// A registered subject in the model frame: the model's topology (with its UVs) at the subject's vertices, rigidly
// aligned to the model's mean shape.
struct Subject {
  std::string name, dir;
  Mesh mesh;
  Image diffuse;  // linear RGB in the template UV
};

// InvalidInput naming the file when the mesh is not in the model's topology (another template) or the diffuse is
// missing or not square.
Subject load_subject(const std::string& dir, const MorphableModel& model);
// load_subject without the diffuse (left empty): for callers that decode the maps themselves (make-dataset bakes them).
Subject load_subject_mesh(const std::string& dir, const MorphableModel& model);

// The head turned by a view's yaw about the model frame's y axis (positive: its left side toward the camera).
Eigen::Matrix3d view_rotation(const ViewSpec& view);

struct ViewFit {
  std::string name;
  double yaw_deg = 0;
  Image render;        // sRGB, render_size², lit: the detector's and the fits' input
  Image bare;          // sRGB, the diffuse alone (unwrapped unless unwrap_lit)
  Coefficients fit;    // canonical camera at render_size (posed_mesh(model, fit) reproduces the render)
  Landmarks68 landmarks;  // what the fits use (px): the detected ones less the view calibration's bias
  Landmarks68 detected;   // the detector's (px)
  Landmarks68 truth_landmarks;  // the subject's landmark vertices (+ landmark_offsets) projected in this view (px)
  double detector_error_px = 0;   // mean distance of the detected landmarks to the truth's projected landmark vertices
  double landmark_rms_px = 0;     // the landmark fit's residual in this view
  double photometric_psnr_db = 0; // the photometric fit's render vs the image (linear, fit_size)
  double shape_error_mm = 0;      // fitted shape vs the subject, mean vertex distance after a rigid alignment
  double alignment_rms_before = 0, alignment_rms_after = 0;  // disagreement with the other views (align.rounds > 0)
  UnwarpResult unwrap;            // through the fit, at input_res
};

struct MergedUnwrap {
  Image colour;      // linear RGB; 0 where no view saw the texel
  Image confidence;  // the largest view confidence
};

// Per texel: Σ_v w_v c_v / Σ_v w_v with w_v = confidence_v^sharpness over the views that saw it. InvalidInput when the
// views differ in size or none is given.
MergedUnwrap merge_by_confidence(const std::vector<const UnwarpResult*>& views, double sharpness);

// The fitted 3DMM in the UV (size²): appearance Ā + B_a δ (linear RGB, resampled bilinearly from the model's
// resolution), unit normals of the shape S(α, β) in the model frame as (n + 1) / 2, and positions of S(α, β) in mm
// stored as (p − offset) / scale in [0, 1]. Texels outside the layout are 0.
struct ModelUvMaps {
  Image albedo, normal, position;
  double position_offset = -160, position_scale = 320;
};
// `uv_raster`: rasterize_uv of the model's topology at size when the caller has it.
ModelUvMaps model_uv_maps(const MorphableModel& model, const Coefficients& fit, int size,
                          const RasterOutput* uv_raster = nullptr);

// SH lighting for light index l: 0 = render/shade.h's default (Deep3DFaceRecon's ambient and a soft key light);
// above, a random light from `seed` around that ambient.
std::array<double, 27> sample_light(int l, uint64_t seed);

// Renders the subject from every view under `light`, detects the landmarks on each lit render (the photo of
// inference), fits the model to them (landmark_fit_mode: one shape for all views with a pose per view or one head
// pose, or independent fits), then per view the photometric fit at fit_size and the unwrap of the diffuse-only render
// (what BareSkinNet hands texture inference: bare skin without light; `unwrap_lit`: the lit render) through its fit.
// InvalidInput naming the subject and view when the detector finds no face. `uv_raster`: rasterize_uv of the model's
// topology at input_res when the caller has it (one for every subject and view); nullptr: made here.
std::vector<ViewFit> fit_views(const MorphableModel& model, const Subject& subject, const std::array<double, 27>& light,
                               const FaceLandmarkDetector& detect, const TextureSampleOptions& options,
                               const RasterOutput* uv_raster = nullptr);

// The subject's landmark vertices plus `offsets` (the detector's convention, model frame; nullptr: none) turned by
// the view and projected by `camera` (px): the points a detector with the calibrated convention and no error finds.
Landmarks68 true_landmarks(const MorphableModel& model, const Subject& subject, const ViewSpec& view,
                           const Camera& camera, const Eigen::Matrix<double, 68, 3>* offsets);

// PSNR (dB) of `a` against `b` over the texels where `mask` > 0, on sRGB-encoded values in [0, 1] (what the network
// sees); both linear RGB of the same size. +inf when identical, NaN when the mask is empty.
double masked_psnr_srgb(const Image& a, const Image& b, const Image& mask);

}  // namespace bareskin::texgen
