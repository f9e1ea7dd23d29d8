// Fitting the morphable model to 2D landmarks (the landmark term of `mm-fit`; BareSkinNet's L_land with L_reg):
// pose (rotation as Rz·Ry·Rx angles, translation in mm), the first identity and expression coefficients α and β,
// minimising Σ |π(R S_k(α, β) + t) − l_k|² + λ (|α|² + |β|²) over the 68 landmarks, with π a fixed pinhole camera (the `render --model`
// camera). Levenberg–Marquardt on a forward-difference Jacobian; α and β are standardised, so λ is in px² per unit.
#pragma once
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "core/image.h"

#include "morphable/coefficients.h"
#include "morphable/model.h"
#include "render/camera.h"

namespace bareskin {

struct LandmarkFit;

struct LandmarkFitOptions {
  int shape_components = 40;       // α fitted (at most the model's)
  int expression_components = 20;  // β fitted (at most the model's)
  double regularisation = 1.0;  // λ
  int iterations = 50;
  // Where Levenberg–Marquardt starts (e.g. a network's answer: its rotation, translation and leading α, β); null:
  // the mean face, frontal, at the origin.
  const LandmarkFit* start = nullptr;
  void check() const;
};

// One point of a fit's progress: after `iteration` steps (0: the start), `seconds` since the fit began, the fit's
// accuracy then (landmark RMS in px, or the photometric PSNR in dB).
struct FitTraceStep {
  int iteration = 0;
  double seconds = 0, value = 0;
};

struct LandmarkFit {
  Eigen::VectorXd alpha, beta;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero(), translation = Eigen::Vector3d::Zero();
  double rms_px = 0;  // landmark reprojection error
  int iterations = 0;
  std::vector<FitTraceStep> trace;  // rms_px after each iteration
};


// The fit's shape and pose as a coefficient file's entries (α, β, rotation, translation; no δ, no γ).
Coefficients to_coefficients(const LandmarkFit& fit);

// landmarks_px: 68 x 2 (pixels, origin top-left). InvalidInput for a model without 68 landmarks or non-finite input.
LandmarkFit fit_landmarks(const MorphableModel& model, const Eigen::MatrixX2d& landmarks_px, const Camera& camera,
                          const LandmarkFitOptions& options = {});

// The photometric term (BareSkinNet's L_diff / L_light with L_reg on δ), with the geometry held at a landmark fit:
// per covered pixel, colour = (Ā + Σ_k δ_k σ_k B_k)(uv) × (Y(n) · γ_c), in linear light, with the normal in the camera
// frame. Gauss-Newton on δ and γ together (the product is bilinear), with the priors below, from Deep3DFaceRecon's
// ambient light.
struct PhotometricFitOptions {
  int appearance_components = 52;
  // A MAP fit: per-pixel colour noise σ_n (linear), δ ~ N(0, 1), and γ ~ N(Deep3DFaceRecon's white ambient, σ_γ²),
  // which settles the albedo-lighting ambiguity (a darker skin under brighter light looks the same).
  double noise = 0.02;
  double lighting_sd = 0.3;
  int iterations = 20;  // Gauss-Newton steps (at most)
  // The skin region: an image of the camera's size whose first channel is > 0.5 where the term may look (e.g. a face
  // parser's skin labels, so that hair, glasses or a hand over the face do not pull δ and γ); nullptr: every pixel
  // the face covers.
  const Image* skin_mask = nullptr;
  void check() const;
};

struct PhotometricFit {
  Eigen::VectorXd delta;
  std::array<double, 27> gamma{};
  double psnr_db = 0;  // of the fitted render against the image over the pixels used, linear values
  int64_t pixels = 0;
  std::vector<FitTraceStep> trace;  // psnr_db after each iteration (seconds include the set-up)
};

// `posed`: the model's topology at the fitted shape and pose; `image` linear RGB of the camera's size.
PhotometricFit fit_photometric(const MorphableModel& model, const Mesh& posed, const Camera& camera, const Image& image,
                               const PhotometricFitOptions& options = {});

// mm-fit --trace: the CSV (stage, iteration, milliseconds since the stage began, value, unit) and beside it one chart
// per stage that ran, <stem>_landmarks.svg and <stem>_photometric.svg: accuracy against time, a marker per iteration.
void write_fit_trace(const std::string& csv_path, const LandmarkFit& fit, const PhotometricFit& photo);

// `bareskin mm-fit` on files: a square image, its 68 landmarks (JSON or .pts, px) and a model; the landmark fit, then
// (unless no_photometric) the photometric fit on the image (inside `skin_mask` when given), written as a coefficient
// file (and with `trace` the trace). InvalidInput for a bad option, an image that is not square or a mask of another
// size; nothing is written then.
struct FitFilesOptions {
  std::string image, model, landmarks;
  std::string output = "fit.json";  // the coefficient file
  std::string view = "front";       // the camera, as `render --model`: front, left or right
  std::string trace, skin_mask;     // "" or the trace CSV; "" or the skin mask image
  LandmarkFitOptions fit;
  PhotometricFitOptions photo;
  bool no_photometric = false;  // landmarks only: no δ or γ
  void check() const;           // InvalidInput naming the flag
};
void fit_files(FitFilesOptions options);

}  // namespace bareskin
