// BareSkinNet (Yang & Taketomi, PG 2022, §4 and §6): the de-makeup and de-lighting network G (pix2pix's U-Net),
// trained in two stages on the face-image world's samples (texgen faces: makeup, before, bare, skin, face, json):
//   stage 1  G alone: L_DD = w1·L1 + w2·L_GAN (PatchGAN D) + w3·L_LPIPS against the target (before or bare);
//   stage 2  G and the student E jointly, the teacher F frozen: L_DD + L_FR with
//            L_FR = w_coeff·L_coeff (E vs F) + w_land·L_land + w_diff·L_diff + w_light·L_light + w_reg·L_reg.
// F reads the before image and gives the reference coefficients C and the light γ; E reads G's output and gives Ĉ.
// The 3DMM is rendered from Ĉ without light (must equal G's output on the rendered face: L_diff, which is how the
// de-lighting reaches G) and with F's γ (must equal the before image: L_light). The ablation rows of the paper's
// Fig. 7 are presets of the same task (ablation_preset). Formulas, weights and rows: docs/training.md, "BareSkinNet".
#pragma once
#include <torch/torch.h>

#include <functional>
#include <map>
#include <memory>
#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bareskinnet/options.h"
#include "core/image.h"
#include "detect/align.h"
#include "recon/face_model.h"
#include "training/losses.h"
#include "training/nets/unet.h"
#include "training/data.h"
#include "training/trainer.h"

namespace bareskin::bsn {

// The name the checkpoints of this task carry.
inline constexpr const char* kTaskName = "bareskinnet";

// Coefficient vectors are recon/face_model.h's: C = (α, β, δ, R, t) in the layout without γ; γ (27) separate.
using CoeffLayout = recon::CoefficientLayout;

// A reconstruction network: its module (whose state a checkpoint keeps) and its forward from aligned images
// ([B, 3, S, S] sRGB in [0, 1], any S) to [B, layout.size()] coefficients, followed by γ [27] where it estimates
// light (F does; E's extra outputs, if any, are ignored).
struct ReconNet {
  std::shared_ptr<torch::nn::Module> module;
  std::function<torch::Tensor(const torch::Tensor& image)> forward;
};

// The 3DMM render stage 2 needs (recon/face_model.h): for coefficients [B, K] and γ [B, 27] at S×S pixels,
// the lit and unlit images ([B, 3, S, S], linear light), the rendered face region [B, 1, S, S] and the 68 landmarks
// [B, 68, 2] in pixels of the S×S image (origin top-left corner).
struct FaceRender {
  torch::Tensor lit, unlit, mask, landmarks;
};
using FaceRenderer = std::function<FaceRender(const torch::Tensor& coeff, const torch::Tensor& gamma, int64_t size)>;

// The renderer of a morphable model (recon/face_model.h) seen by the canonical camera at the training size.
FaceRenderer model_renderer(std::shared_ptr<const recon::FaceModel> model);

// The loss terms of L_FR, unweighted, on tensors (exposed for tests). Images in linear light.
// L_diff: Σ m·|unlit − g_out| / Σ m over the rendered region m (with `gain`, Options::diff_gain: unlit times its
// least-squares gain to g_out per image and channel, detached); L_light: the same for lit against the before image.
torch::Tensor diff_loss(const torch::Tensor& unlit, const torch::Tensor& g_out_linear, const torch::Tensor& mask,
                        bool gain = false);
torch::Tensor light_loss(const torch::Tensor& lit, const torch::Tensor& before_linear, const torch::Tensor& mask);
// L_land: mean over landmarks and batch of the squared distance in pixels of the 256² canonical frame (`scale` =
// 256 / S converts S×S pixels); L_coeff: mean squared difference of the coefficients; L_reg: per face Σα² + Σβ² +
// Σδ² (standard deviations: the mean face is 0), averaged over the batch.
torch::Tensor landmark_loss(const torch::Tensor& projected, const torch::Tensor& target, double scale);
torch::Tensor coeff_loss(const torch::Tensor& student, const torch::Tensor& teacher);
torch::Tensor reg_loss(const torch::Tensor& coeff, const CoeffLayout& layout);
// L_level: mean over batch and channels of |Σ m·(a − b) / Σ m| (images [B, C, H, W], mask [B, 1, H, W]).
torch::Tensor level_loss(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask);

// The EMA's decay at update n (0-based): min(decay, (1 + n) / (10 + n)), so the first updates follow G closely and
// the starting weights are forgotten within a few dozen steps even at decay 0.999.
double ema_decay(double decay, int64_t n);
// average ← d·average + (1 − d)·model over every parameter and floating-point buffer (batch-norm running mean and
// variance); integer buffers (batch counts) are copied. The two modules must have the same layout. d = 0 copies.
void ema_update(torch::nn::Module& average, torch::nn::Module& model, double d);

// G_ema and its update count, one module so that checkpoints keep both ("G_ema.G.*", "G_ema.updates"); training
// writes it, load_generator reads it.
struct GeneratorEmaImpl : torch::nn::Module {
  explicit GeneratorEmaImpl(std::shared_ptr<nets::UNetImpl> g)
      : G(register_module("G", std::move(g))), updates(register_buffer("updates", torch::zeros({}, torch::kLong))) {
    for (auto& p : G->parameters()) p.set_requires_grad(false);
  }
  std::shared_ptr<nets::UNetImpl> G;
  torch::Tensor updates;
};

// sRGB-encoded [0, 1] → linear light (the IEC 61966-2-1 curve), differentiable.
torch::Tensor srgb_to_linear(const torch::Tensor& x);

// The makeup of a training example (members makeup and before, [3, H, W] sRGB in [0, 1]) in another hue: with
// probability `probability`, makeup ← clamp(before + R(θ)·(makeup − before), 0, 1), R(θ) the rotation about the grey
// axis by θ uniform in [0, 2π), all drawn from `seed`. Pixels the makeup left alone stay as they are; the change's
// length and its grey part are kept. Without a before member the example is left alone.
void rotate_makeup_hue(data::Example& example, uint64_t seed, double probability);
// The makeup of a training example painted over in opaque colours of any hue (members makeup, before and bare,
// [3, H, W] sRGB in [0, 1]; face [1, H, W] optional): with probability `probability`, where the makeup changed the
// face most (mean |makeup − before| over the channels from 0.04 to 0.1: lips, eyes, cheeks; foundation stays),
// a layer of opacity o·that ramp, o uniform in [0.5, 1], and of one colour above row 0.55·H (eyes, brows) and
// another below (lips), each of a uniform hue, saturation in [0.3, 1] and value in [0.1, 1], is composed over the
// makeup in linear light and lit by the photo's own light (before / bare, per pixel and channel). All drawn from
// `seed`; an example without these members is left alone.
void paint_makeup(data::Example& example, uint64_t seed, double probability);
// Where the makeup changed the face: mean |makeup − before| over the channels > 0.02, on the face region (≥ 0.5);
// [B, 1, H, W] of 0 and 1. L_makeup's region and the evaluation's makeup_* region.
torch::Tensor makeup_region(const torch::Tensor& makeup, const torch::Tensor& before, const torch::Tensor& face);
// Images [B, C, H, W] area-resized to s × s (returned as they are when already that size): how the shards' 256²
// members reach G's training size.
torch::Tensor area_resized(const torch::Tensor& t, int64_t s);
// The pixels of an area-resized mask ([B, 1, H, W]) whose whole footprint lay in the mask at the shards' size:
// [B, 1, H, W] of 0 and 1. The regions every metric is taken over. A pixel on the face's outline at G's size is
// partly hair or background in the photo, while the bare truth (black off the face) is darkened there: no G could
// match it. At the shards' own size the masks are already whole pixels and nothing changes.
torch::Tensor whole_footprint(const torch::Tensor& resized_mask);
// Skin-region metrics of one image pair ([B, 3, H, W] in [0, 1], mask [B, 1, H, W]): PSNR over the masked pixels,
// SSIM averaged over the window positions whose centre is in the mask. Per image, [B]. With a `domain` ([B, 1, H, W],
// where b is a truth at all) each window compares the pair on the domain's pixels alone (losses::ssim_map with a
// domain): the bare truth is black off the face, and a window on the face's outline or beside an occluder would
// otherwise score G's hair, background or sunglasses against that black.
torch::Tensor masked_psnr(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask);
torch::Tensor masked_ssim(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask,
                          const torch::Tensor& domain = {});
// Where the truth member `truth` is a truth, given the sample's face mask at G's size (face.png area-resized;
// undefined for shards without one): for "bare" the face's whole pixels (the bare albedo is black off the face and
// shows the face under occluders, which no photo does); for any other member an undefined tensor: the whole image.
torch::Tensor truth_domain(const std::string& truth, const torch::Tensor& resized_face);

class BareSkinTask : public train::Task {
 public:
  // Stage 1 needs neither F nor E nor the renderer. Stage 2 needs F and the renderer, and E when options.recon is
  // "E". Modules are built in a fixed order (G, D, E), so seed before constructing.
  BareSkinTask(Options options, ReconNet teacher = {}, ReconNet student = {}, FaceRenderer renderer = {},
               CoeffLayout layout = {});

  std::string name() const override { return kTaskName; }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override;
  std::vector<train::OptimizerSpec> optimizers() override;  // "D", then "G" (G with E, or a tuned F, as groups)
  train::Losses loss(size_t phase, const data::Batch& batch) override;
  std::map<std::string, double> evaluate(const data::Batch& batch) override;
  std::vector<std::vector<torch::Tensor>> samples(const data::Batch& batch) override;

  // G on aligned images [B, 3, S, S] in [0, 1] → the bare-skin images in [0, 1].
  torch::Tensor generate(const torch::Tensor& images);
  // The batch's member at the training size (area resize; landmarks scaled).
  torch::Tensor member(const data::Batch& batch, const std::string& name) const;
  // G's supervision at the training size: the before image, or for target "bare" the bare albedo on the face region
  // (face.png) and the input elsewhere.
  torch::Tensor target(const data::Batch& batch) const;

  const Options& options() const { return options_; }
  std::shared_ptr<torch::nn::Module> generator() const;
  // G_ema (Options::ema > 0), else null; and the number of updates it has had.
  std::shared_ptr<torch::nn::Module> generator_ema() const;
  int64_t ema_updates() const;
  // Restarts the average at G's current weights (the start of a stage).
  void reset_ema();
  // The number of steps of the stage, which places the learning-rate decay (Options::lr_decay); set it before the
  // Trainer asks for the optimizers.
  void set_stage_steps(int64_t steps) { stage_steps_ = steps; }

 private:
  struct Nets;
  Options options_;
  ReconNet teacher_, student_;
  FaceRenderer renderer_;
  CoeffLayout layout_;
  std::shared_ptr<Nets> nets_;
  torch::Tensor cached_output_;  // G's output of the D phase, reused by the G phase of the same step
  int64_t stage_steps_ = 0;
  torch::Tensor generate_eval(const torch::Tensor& images);  // G_ema when on, else G
};

// Stage 2 starts from stage 1's G and D: copies them from a finished stage-1 run's checkpoint into the task
// (before its Trainer starts); G_ema, when on, restarts at that G. InvalidInput naming the file when it is not a
// BareSkinNet checkpoint.
void start_from_stage1(BareSkinTask& task, const std::string& stage1_checkpoint);

// What stage 2 needs besides G and D, made after seeding (the teacher loaded from its run, a fresh student).
struct Stage2Parts {
  ReconNet teacher, student;
  FaceRenderer renderer;
  CoeffLayout layout;
};

struct RunOptions {
  Options task;                    // its `stage` is set per stage
  std::string train_data;          // a faces split folder (manifest.json) or one shard
  std::string val_data;            // optional: validation metrics and sample grids
  std::string run_dir;             // stage1/ and stage2/ are written inside
  int64_t steps1 = 10000, steps2 = 30000;  // the paper's; steps2 = 0: stage 1 only
  int64_t batch = 4;
  uint64_t seed = 0;
  int decode_threads = 2;
  train::TrainerOptions trainer;   // intervals, device, progress, resume (run_dir, steps, config are set here)
  std::string teacher, model;      // recorded in the run's configuration (demakeup's defaults)
  nlohmann::json profile = nlohmann::json::object();  // the command's --profile and the flags given over it
  void check() const;  // InvalidInput naming the flag (and task.check(), the trainer's intervals)
};
void to_json(nlohmann::json& j, const RunOptions& o);

struct RunResult {
  train::TrainResult stage1, stage2;
};

// Runs stage 1 into run_dir/stage1, then stage 2 into run_dir/stage2 from stage 1's G and D. With
// trainer.resume a finished stage is skipped and an unfinished one continues from its checkpoint; a stage-2 run
// continued at the switch repeats an uninterrupted one to the bit.
RunResult train_two_stages(const RunOptions& options, const std::function<Stage2Parts()>& make_parts);

// The teacher F of a recon run (`bareskin train recon`; a run folder or its checkpoint) for this model, its input
// resized to the size F was trained at. InvalidInput naming the file when the checkpoint belongs to another task
// or holds no F, or when F's head does not fit the model.
ReconNet load_teacher(const std::string& run, const recon::FaceModel& model);
// The checks of load_teacher that need no model (the checkpoint's task and its F); returns the checkpoint's path.
std::string check_teacher(const std::string& run);
// A fresh student E (ResNet-18 by default, no light) for this model; `options` over recon::ReconNetOptions.
ReconNet make_student(const recon::FaceModel& model, const nlohmann::json& options = nlohmann::json::object());

// The shard members a task reads.
std::vector<std::string> required_members(const Options& o);

// ---- Inference: `bareskin demakeup` and texture inference call this. ----

// A trained BareSkinNet ready for photos: G of a run, the teacher F and the morphable model.
struct Demakeup {
  std::shared_ptr<torch::nn::Module> G;  // nets::UNetImpl
  // G prepared for inference (nets::UNetInference: batch norms folded, CPU-fast upsampling); run_generator uses it
  // when set (load and load_generator set it), else G.
  std::shared_ptr<const nets::UNetInference> G_inference;
  int64_t size = 256;                    // G's training resolution
  std::string head = "image";            // how G's image comes from the U-Net (Options::head of its run)
  // The residual or affine head's maps applied to the photo at its own size, which keeps the photo's detail finer
  // than G's size: for a G trained towards the before image (it keeps the photo's light). A G trained towards the
  // bare albedo must also remove the light's fine detail (highlights, shadow edges), which its maps at its own size
  // cannot, so its image is upsampled instead (Table 1 (b) 0.5–0.7 dB better; bench/BENCHMARKS.md).
  bool maps_at_photo_size = false;
  bool skip_g = false;                   // "without BareSkinNet": the photo as it is (the baseline)
  // G's image averaged with the mirror image of G's image of the mirrored photo (an aligned face is near-symmetric,
  // G's errors are not): twice G's time; G's image +0.27 dB on the reference's held-out faces, but F's albedo of it
  // −0.7 dB after stage 2 (bench/BENCHMARKS.md), so off unless asked for.
  bool flip_average = false;
  ReconNet F;
  std::shared_ptr<recon::FaceModel> model;
  torch::Tensor uvs, uv_triangles, uv_vertex;  // the model's UV layout: [T, 2], [F, 3], model vertex per UV vertex
  torch::Device device = torch::kCPU;
  // G from run/stage2 (else run/stage1), its moving average G_ema where the run kept one; F and the model from
  // `teacher` / `model`, or from the run's configuration
  // when empty. InvalidInput naming the file for a checkpoint of another task; IoError for missing files.
  static Demakeup load(const std::string& run, const std::string& teacher = "", const std::string& model = "",
                       torch::Device device = torch::kCPU);
  // The model and its UV layout alone (no G, no F): what unwarp_to_uv needs.
  static Demakeup with_model(const std::string& model, torch::Device device = torch::kCPU);
};

struct DemakeupResult {
  double score = 0;                         // the detector's
  Eigen::Matrix<double, 68, 2> landmarks;   // photo pixels
  Eigen::Matrix<double, 2, 3> similarity;   // photo → aligned
  torch::Tensor aligned;                    // [3, 256, 256] sRGB: the input G saw
  torch::Tensor bare;                       // [3, 256, 256] sRGB: G's bare-skin image
  torch::Tensor coefficients;               // [K + 27]: F's fit of the bare-skin image (α, β, δ, R, t, γ)
  torch::Tensor unlit, mask;                // [3, 256, 256] sRGB albedo render of the fit, [1, 256, 256] its coverage
  torch::Tensor uv, uv_mask;                // [3, R, R] sRGB bare skin in the template UV (row 0 = v 1), [1, R, R] seen
  std::map<std::string, double> ms;         // wall milliseconds per stage: detect, align, G, F, render, unwarp
};

// G on aligned faces [B, 3, 256, 256] sRGB → bare-skin images (G runs at its training size, the output is resized
// back; with Demakeup::flip_average, the mean of G's image and the mirror of G's image of the mirrored faces).
torch::Tensor run_generator(const Demakeup& d, const torch::Tensor& aligned);

// Photo (an sRGB-encoded RGB image, values in [0, 1]) → detect (the best face) → align (detect/align.h) → G → F →
// unlit render → unwarp. InvalidInput naming `source` when no face is found.
DemakeupResult demakeup(const Demakeup& d, const Image& photo, const detect::PhotoDetector& detector,
                        int64_t uv_size = 1024, const std::string& source = "photo");

// An image (values in [0, 1]) as a [C, H, W] float tensor.
torch::Tensor image_tensor(const Image& image);

// The same from an already aligned face [3, 256, 256] sRGB (a texgen faces sample, or a photo aligned elsewhere):
// score 0, no landmarks, the identity similarity.
DemakeupResult demakeup_aligned(const Demakeup& d, const torch::Tensor& aligned, int64_t uv_size = 1024);

// One result as files in `dir` (made here), each written atomically: aligned.png, bare.png, unlit.png (the fit's
// albedo render on its coverage), uv.png + uv_mask.png, coefficients.json (the coefficient file with the photo, the
// alignment, the camera; `detected`: the detector's score and landmarks).
void write_demakeup(const DemakeupResult& r, const Demakeup& d, const std::string& dir, const std::string& photo,
                    bool detected = true);

// An image [B, 3, S, S] into the model's UV through the coefficients (canonical camera at S): per texel the image at
// the projected surface point where that point is the nearest surface along its ray (depth within
// `depth_tolerance` mm) and faces the camera. Returns the UV image [B, 3, R, R] and the seen mask [B, 1, R, R].
std::pair<torch::Tensor, torch::Tensor> unwarp_to_uv(const Demakeup& d, const torch::Tensor& images,
                                                     const torch::Tensor& coefficients, int64_t uv_size,
                                                     double depth_tolerance = 2.0);

// ---- Evaluation on held-out faces (the test split: unseen subjects and, with texgen's --exclude-styles, unseen
// makeup styles). ----
struct EvalOptions {
  std::string lpips_trunk = "vgg16-random";  // LPIPS of the skin region (masked images); "" = none
  std::string face_api;                      // face-api folder: facenet LPIPS and the identity cosine ("" = no identity)
  int64_t batch = 4;
  int64_t max_samples = 0;  // 0: all
  torch::Device device = torch::kCPU;
  void check() const;  // InvalidInput for an unknown trunk or a bad count
};
struct EvalResult {
  int64_t samples = 0;
  double ms_per_image = 0;  // G alone, batch 1 at its training size on this device (median)
  std::map<std::string, double> mean;  // psnr_bare, ssim_bare, lpips_bare, psnr_before, ..., identity_bare,
                                       // and the input's own (psnr_input_bare ...): the do-nothing baseline
  std::map<std::string, std::map<std::string, double>> by_style;  // the same per makeup style
};
void to_json(nlohmann::json& j, const EvalResult& r);
// G of a trained Demakeup (its model and F are not needed) on every sample of `split` (a folder with manifest.json),
// at G's training resolution (the samples area-resized to it; skin where the whole footprint is: whole_footprint).
EvalResult evaluate_generator(const Demakeup& d, const std::string& split, const EvalOptions& options);
// G alone from a run (stage2, else stage1; G_ema where the run kept one): the Demakeup evaluate_generator takes.
Demakeup load_generator(const std::string& run, torch::Device device = torch::kCPU);

struct RunEvalOptions {
  std::string lpips_trunk = "vgg16-random";  // facenet falls back to none without face-api's recognition net
  int64_t max_samples = 0;                   // 0: all
  torch::Device device = torch::kCPU;
  bool required = false;  // InvalidInput when the test split is missing (else nothing is done)
  bool quiet = false;     // no summary line on stderr
  void check() const;     // InvalidInput for an unknown trunk or a bad count
};
// The held-out evaluation of a run (`train bareskin`): G of `run` on <data>/test (unseen subjects and makeup styles)
// into <run>/eval.json, with the LPIPS trunk and the split recorded.
void evaluate_run(const std::string& run, const std::string& data, const RunEvalOptions& options);

// G's image from the U-Net's output (Options::head), in [0, 1] units; `images` [B, 3, S, S] in [0, 1]. Not clamped
// (training sees the raw value; inference clamps). apply_head: the same from the U-Net's Tanh output `y`.
torch::Tensor generator_forward(nets::UNetImpl& G, const torch::Tensor& images, const std::string& head);
torch::Tensor apply_head(const torch::Tensor& images, const torch::Tensor& y, const std::string& head);

// The U-Net options for a training size and head: the zoo's unet256 with num_downs = log2(size) (≥ 5) and the
// head's output channels, overridden by `g`.
nlohmann::json generator_options(const nlohmann::json& g, int64_t size, const std::string& head);

}  // namespace bareskin::bsn
