// 3D face reconstruction by network (BareSkinNet §3.3: the teacher F, a ResNet-50 regressing C = (α, β, δ, R, t) and
// the SH light γ from a 256² aligned face, and the student E, a ResNet-18; Deep3DFaceRecon's recipe): the nets with
// their zero-initialised heads, the losses through the differentiable face model (recon/face_model.h), the
// training Task, and the metrics. docs/training.md, "Face reconstruction (F / E)".
#pragma once
#include <torch/torch.h>

#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "detect/face_recognition.h"
#include "recon/face_model.h"
#include "training/nets/resnet.h"
#include "training/trainer.h"

namespace bareskin::recon {

// The sRGB transfer functions on tensors (exact piecewise form; differentiable).
torch::Tensor srgb_to_linear(const torch::Tensor& encoded);
torch::Tensor linear_to_srgb(const torch::Tensor& linear);

struct ReconNetOptions {
  std::string arch = "resnet50";  // resnet50 (F) | resnet18 (E) | resnet34
  int width = 64;                 // conv1 / layer1 channels (torchvision: 64); small values make tiny nets
  bool gamma = true;              // regress the light (F); E does not
  double translation_scale = 10;  // mm per unit of the translation head's output
  int pool_grid = 1;              // the heads read layer4 averaged over pool_grid² cells (1: the global average)
  void check() const;             // InvalidInput for an unknown arch or a bad value
};
void to_json(nlohmann::json& j, const ReconNetOptions& o);
void from_json(const nlohmann::json& j, ReconNetOptions& o);  // InvalidInput: unknown key, wrong type, bad value

// Backbone (torchvision ResNet without its fc), global average pooling (or, with pool_grid g > 1, the average over
// each cell of a g × g grid, flattened: where a feature is, not only how strong), one zero-initialised linear head per group
// (so an untrained net answers the mean face, frontal, at the origin, under Deep3DFaceRecon's ambient light):
// α K_id, β K_exp, δ K_app, rotation 3 (radians), translation 3 (× translation_scale mm), γ 27 (+0.8 on each channel's
// first coefficient). The output is a row of the coefficient vector (face_model.h), in the coefficient file's units.
class ReconNetImpl : public torch::nn::Module {
 public:
  ReconNetImpl(const ReconNetOptions& options, const CoefficientLayout& model_layout);
  // [B, 3, H, W] sRGB in [0, 1] (an aligned face; Deep3DFaceRecon's input) → [B, layout().size()].
  torch::Tensor forward(const torch::Tensor& image);
  const CoefficientLayout& layout() const { return layout_; }
  const ReconNetOptions& options() const { return options_; }

 private:
  ReconNetOptions options_;
  CoefficientLayout layout_;
  nets::ResNet backbone_{nullptr};
  torch::nn::Linear alpha_{nullptr}, beta_{nullptr}, delta_{nullptr}, rotation_{nullptr}, translation_{nullptr},
      gamma_{nullptr};
};
TORCH_MODULE(ReconNet);

enum class Supervision { Truth, Self, Both };
Supervision parse_supervision(const std::string& name);  // truth | self | both; InvalidInput otherwise
std::string to_string(Supervision s);
void to_json(nlohmann::json& j, Supervision s);         // its name
void from_json(const nlohmann::json& j, Supervision& s);  // InvalidInput for an unknown name

// Loss weights. Deep3DFaceRecon's defaults for the self-supervised terms; the supervised term's units: α, β, δ in
// standard deviations, rotation in rotation_unit rad, translation in translation_unit mm, γ in gamma_unit.
struct LossOptions {
  Supervision supervision = Supervision::Both;
  double truth = 1.0;  // the coefficient loss: Σ_g w_g mean((ĉ_g − c_g)² / unit_g²)
  double w_alpha = 1, w_beta = 1, w_delta = 1, w_rotation = 1, w_translation = 1, w_gamma = 1;
  double rotation_unit = 0.05, translation_unit = 5, gamma_unit = 0.1;
  double shape = 0;          // mean per-vertex distance (mm) of S(α̂, β̂) from the true S(α, β) (the metric shape_mm)
  double photo = 1.92;       // per-pixel Euclidean colour distance over the skin the face covers
  double landmark = 1.6e-3;  // squared px at 224² (our 256² landmarks are scaled), weight 20 on 28–30 and 60–67
  double reg = 3e-4, reg_alpha = 1.0, reg_beta = 0.8, reg_delta = 1.7e-2;
  double gamma_mono = 10;  // γ's spread over the colour channels
  double identity = 0.2;   // 1 − cos of face-api's descriptors of the render (over the input) and the input
  void check() const;      // InvalidInput for a negative weight or unit
};
void to_json(nlohmann::json& j, const LossOptions& o);
void from_json(const nlohmann::json& j, LossOptions& o);  // InvalidInput: unknown key, wrong type, bad value

// What the losses compare against, decoded from a batch of face samples (docs/file_formats.md, face samples).
struct ReconTargets {
  torch::Tensor image;            // [B, 3, H, W] sRGB in [0, 1]: the net's input and the photometric target
  torch::Tensor skin;             // [B, 1, H, W] in {0, 1}: where the photometric term looks (all ones if absent)
  torch::Tensor landmarks;        // [B, 68, 2] px, or undefined
  torch::Tensor landmark_weight;  // [B, 68]: visibility (1 where absent)
  torch::Tensor truth;            // [B, K] coefficients with γ (zeros where a sample has none)
  torch::Tensor has_truth;        // [B] 1 where the sample's json holds coefficients and "has_truth" is not false
};
// `input`: the member the net sees ("before": lit, no makeup; "makeup"). InvalidInput naming the sample for a
// missing member or coefficients of another model.
ReconTargets targets_from_batch(const data::Batch& batch, const FaceModel& model, const std::string& input = "before");

// A per-channel colour gain, drawn per sample, so F cannot tell a trained identity by its skin's colour alone
// (`train recon --colour-jitter s`). Each channel's gain is exp(s·u), u uniform in [-1, 1] (s 0.2: ×0.82 … ×1.22),
// applied to `member` in linear light; the light γ of the sample's coefficients is scaled by the same gains, so
// the pair stays exact (colour = albedo · (Y(n) · γ) + specular, each linear in the channel's light). No-op at s 0.
void jitter_colour(data::Example& example, const std::string& member, double strength, uint64_t seed);

// The targets at another square size (the nets train and answer at any size; the canonical camera scales with it):
// images area-resampled, the skin mask re-thresholded at 0.5, landmarks scaled.
ReconTargets resized(const ReconTargets& targets, int64_t size);

// The terms (Deep3DFaceRecon's definitions; images in linear light, the render against the decoded input).
torch::Tensor photo_loss(const torch::Tensor& rendered, const torch::Tensor& target, const torch::Tensor& mask);
torch::Tensor landmark_loss(const torch::Tensor& predicted, const torch::Tensor& target, const torch::Tensor& visible,
                            int64_t image_size);
torch::Tensor gamma_loss(const torch::Tensor& gamma);  // [B, 27]
torch::Tensor coefficient_loss(const torch::Tensor& predicted, const torch::Tensor& truth,
                               const torch::Tensor& has_truth, const CoefficientLayout& layout, const LossOptions& o);

// The shape term: mean over the samples with truth and the vertices of |S(α̂, β̂) − S(α, β)| in mm (the model frame).
torch::Tensor shape_loss(const FaceModel& model, const torch::Tensor& predicted, const torch::Tensor& truth,
                         const torch::Tensor& has_truth);

// Every weighted term of `predicted` [B, K] (named "truth", "shape", "photo", "landmark", "reg", "gamma", "identity"; only
// those the supervision and weights switch on). `light` [B, 27] lights a prediction without γ (else the truth's γ).
// `identity_net` may be null when o.identity is 0.
train::Losses recon_losses(const FaceModel& model, const torch::Tensor& predicted, const ReconTargets& targets,
                           const LossOptions& o, detect::FaceRecognitionNet* identity_net, int64_t image_size);

// Accuracy of predictions against the truth, per face (vectors of B): shape_mm (mean per-vertex distance of
// S(α, β) in the model frame), posed_mm (of R S + t), landmark_px (RMS of the projected landmarks against the
// sample's), skin_psnr (dB, linear light, lit render vs the input over skin ∩ face), gamma_rmse, alpha/beta/delta
// RMS errors in σ. Faces without truth get NaN for the truth-based ones.
std::map<std::string, std::vector<double>> recon_metrics(const FaceModel& model, const torch::Tensor& predicted,
                                                         const ReconTargets& targets, int64_t image_size);

struct ReconTaskOptions {
  ReconNetOptions net;
  LossOptions loss;
  std::string input = "before";
  double lr = 1e-4;
  train::Schedule schedule{"step", 0, 0, 0.2};  // ×0.2 every schedule.step_every steps (Deep3DFaceRecon)
  int64_t image_size = 256;
  void check() const;  // InvalidInput for an unknown input or a bad value (and the nested options' check())
};

// The Trainer's task: one net "F" (resnet50 / with γ) or "E", one Adam optimizer.
class ReconTask : public train::Task {
 public:
  ReconTask(const ReconTaskOptions& options, FaceModel model, std::shared_ptr<detect::FaceRecognitionNet> identity,
            torch::Device device);
  std::string name() const override { return "recon"; }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override;
  std::vector<train::OptimizerSpec> optimizers() override;
  train::Losses loss(size_t phase, const data::Batch& batch) override;
  std::map<std::string, double> evaluate(const data::Batch& batch) override;
  std::vector<std::vector<torch::Tensor>> samples(const data::Batch& batch) override;
  ReconNet net() const { return net_; }
  std::string module_name() const;

 private:
  ReconTaskOptions options_;
  FaceModel model_;
  std::shared_ptr<detect::FaceRecognitionNet> identity_;
  torch::Device device_;
  ReconNet net_{nullptr};
};

// The render of predictions over the input (sRGB [B, 3, H, W]): the lit face where it covers, the photo elsewhere.
torch::Tensor overlay(const FaceModel& model, const torch::Tensor& predicted, const torch::Tensor& image,
                      const torch::Tensor& light = torch::Tensor());

// A trained F or E ready for inference: the net of a `bareskin train recon` run with the model it was trained for.
struct TrainedRecon {
  ReconNet net{nullptr};
  FaceModel model;
  int64_t image_size = 256;
  std::string module;  // "F" or "E"
  nlohmann::json config;
  torch::Device device = torch::kCPU;
};
// `run`: a run folder or its checkpoint. IoError when missing; InvalidInput naming the checkpoint when it is not a
// recon run, was trained for a model with other sizes (both named), or its weights do not fit the net it describes.
TrainedRecon load_recon(const std::string& run, const FaceModel& model, torch::Device device = torch::kCPU);
// The morphable model of a `bareskin train recon` run (its folder or checkpoint): `model` when given, else the one
// the run's config.json names. IoError without the checkpoint, InvalidInput when the config names no model.
std::string run_model_path(const std::string& run, const std::string& model = "");

// How far to trust an answer: the net's projected landmarks against the detector's (RMS px in the 256² aligned
// frame) and the lit render against the photo over the face (PSNR, linear light). `flagged` when either passes its
// threshold (docs/training.md: calibrated on held-out renders; bench/BENCHMARKS.md gives the rates).
struct ConfidenceOptions {
  double landmark_px = 4.0;  // flag above
  double psnr_db = 20.0;     // flag below
  void check() const;        // InvalidInput for a threshold that is not a positive number
};
struct Reconstruction {
  torch::Tensor coefficients;  // [K] with γ (E answers Deep3DFaceRecon's ambient light), CPU float
  torch::Tensor landmarks;     // [68, 2] projected, aligned frame px
  torch::Tensor overlay;       // [3, S, S] sRGB: the lit render over the input
  double landmark_residual_px = std::numeric_limits<double>::quiet_NaN();  // vs `detected` (NaN without)
  double psnr_db = 0;
  double confidence = 0;  // in (0, 1]: exp(−½ (r/r₀)²) · σ((psnr − psnr₀) / 2)
  bool flagged = false;
  double milliseconds = 0;  // the forward pass
};
// aligned: [3, S, S] sRGB in [0, 1] (detect/align.h's frame, S = the net's image size); detected: [68, 2] landmarks
// in that frame, or undefined.
Reconstruction reconstruct(const TrainedRecon& recon, const torch::Tensor& aligned, const torch::Tensor& detected,
                           const ConfidenceOptions& confidence = {});

// Face samples rendered by the face model from random coefficients, in the format `texgen faces` writes (members
// before.png and makeup.png (the same lit render over a noisy background), skin.png (skin the face covers: not eyes,
// brows or mouth), face.png, json with subject, split, coefficients, landmarks, camera, has_truth), as a dataset
// folder with manifest.json: the fixture of the trainer's tests and of runs without `texgen faces`.
struct RenderedFacesOptions {
  int64_t count = 16;
  int size = 64;
  uint64_t seed = 1;
  double sigma = 1.0;     // α, β, δ ~ N(0, sigma²)
  double max_yaw = 0.35;  // radians, uniform in ±max_yaw
  int64_t per_shard = 256;
  std::string split = "train";
  void check() const;  // InvalidInput when out of range
};
void write_rendered_faces(const std::string& dir, const FaceModel& model, const RenderedFacesOptions& options);

}  // namespace bareskin::recon
