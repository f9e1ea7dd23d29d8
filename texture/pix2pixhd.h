// Texture inference (BareSkinNet §5): pix2pixHD from the UV inputs (unwrapped bare-skin image and its confidence,
// 3DMM albedo, 3DMM normal, 3DMM position) to the four maps (diffuse, normal, roughness, specular) at 1K, as a Task of
// training/trainer.h; the trained generator is loaded back for inference with TextureNet. docs/texture.md describes
// the method.
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "texture/maps.h"
#include "training/nets/pix2pixhd.h"
#include "training/trainer.h"
#include "training/vgg16.h"

namespace bareskin::texture {

// Random occlusion masks for training (paper §5: unwrapped skin masks multiplied into the face texture each step).
// From a `masks/` shard set (member mask.png, grey UV visibility), or synthetic: unions of random ellipses and
// half-planes (hair, hands, glasses-like bands) cut out of an all-visible map. Draws use LibTorch's default
// generator, so a resumed run draws what the uninterrupted run did.
class OcclusionSampler {
 public:
  OcclusionSampler() = default;                          // synthetic
  explicit OcclusionSampler(torch::Tensor masks);        // [N, 1, H, W] in [0, 1]
  // Reads up to `max_masks` masks of a shard set (a folder with manifest.json or a .tar) at res².
  static OcclusionSampler from_shards(const std::string& dataset, int64_t res, int64_t max_masks = 1024);
  // [batch, 1, res, res] in [0, 1] (1 = visible).
  torch::Tensor sample(int64_t batch, int64_t res) const;
  int64_t count() const { return masks_.defined() ? masks_.size(0) : 0; }

 private:
  torch::Tensor masks_;
};
// The mask multiplied into the unwrap and its confidence (the first four channels of stacked inputs in [0, 1]); the
// 3DMM channels are left as they are.
torch::Tensor occlude(const torch::Tensor& inputs01, const torch::Tensor& mask);

// The maps a renderer has without texture inference, the baseline every texture net must beat: the 3DMM albedo as
// the diffuse, the flat tangent-space normal, and for roughness and specular (which the 3DMM does not model) the best
// constant, the truth's own mean over each sample's layout. From the stacked inputs in [−1, 1], the truth in [0, 1]
// ([B, 8, H, W]) and the layout; [B, 8, H, W] in [0, 1].
torch::Tensor mm_only_maps(const torch::Tensor& inputs, const torch::Tensor& truth01, const torch::Tensor& layout);
// The texels of the model's UV layout, where the 3DMM normal map is drawn: [B, 1, H, W], 0 or 1, from the stacked
// inputs in [−1, 1]. The texture evaluation scores maps over these texels, as `bareskin evaluate` does.
torch::Tensor uv_layout(const torch::Tensor& inputs);

// ---- pix2pixHD ----
struct TextureNetOptions {
  // "global" (GlobalGenerator) | "local" (LocalEnhancer around it) | "uv" (texture/uvnet.h: a U-Net correcting the
  // unwrap and the 3DMM's maps)
  std::string generator = "global";
  nlohmann::json generator_options = nlohmann::json::object();      // zoo options over the defaults (ngf, ...)
  nlohmann::json discriminator_options = nlohmann::json::object();  // pix2pixhd_multiscale_d options
  int64_t res = 1024;             // the maps' side (multiple of 2^n_downsampling)
  double lambda_gan = 1;          // the adversarial term (pix2pixHD: 1)
  double lambda_feat = 10;        // feature matching
  double lambda_perceptual = 10;  // VGG loss (pix2pixHD: λ_feat as well); 0 = off
  double lambda_l1 = 0;           // optional L1 to the targets (not in pix2pixHD; off by default)
  double lr = 2e-4, beta1 = 0.5, beta2 = 0.999;
  double lr_decay = 0.5;  // the rate falls linearly to 0 from this fraction of the steps on (0.5: niter = niter_decay)
  double clip_grad_norm = 0;  // each step's gradients scaled to at most this norm (per network); 0: off
  int64_t steps = 1000;   // the run's length (where the decay starts)
  void check() const;     // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const TextureNetOptions& o);
// InvalidInput: unknown key, wrong type, bad value. Reads the configuration of runs from before lr_decay too: their
// "decay_start" (a step, -1 for half the run) becomes the same fraction.
void from_json(const nlohmann::json& j, TextureNetOptions& o);

// The generator of a texture run, built from options: 13 input channels → 8 outputs in (−1, 1).
std::shared_ptr<torch::nn::Module> make_texture_generator(const TextureNetOptions& options);
torch::Tensor run_generator(torch::nn::Module& generator, const torch::Tensor& x);

class Pix2PixHDTask : public train::Task {
 public:
  Pix2PixHDTask(TextureNetOptions options, OcclusionSampler occlusion);
  std::string name() const override { return "pix2pixhd-texture"; }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override;
  std::vector<train::OptimizerSpec> optimizers() override;  // "G" then "D" (pix2pixHD's order)
  train::Losses loss(size_t phase, const data::Batch& batch) override;
  std::map<std::string, double> evaluate(const data::Batch& batch) override;  // PSNR per map, dB
  std::vector<std::vector<torch::Tensor>> samples(const data::Batch& batch) override;

  // The network input of a batch at the task's size ([−1, 1]); with `mask`, occluded by it.
  torch::Tensor input(const data::Batch& batch, const torch::Tensor& mask = {}) const;
  torch::Tensor target(const data::Batch& batch) const;  // [−1, 1]
  torch::nn::Module& generator() { return *G_; }

 private:
  bool adversarial() const;  // λ_gan or λ_feat > 0: D is built and trained
  void make_discriminator();
  TextureNetOptions options_;
  OcclusionSampler occlusion_;
  std::shared_ptr<torch::nn::Module> G_;
  nets::MultiscaleDiscriminator D_{nullptr};
  losses::Vgg16Features vgg_{nullptr};
  // G's phase hands its (occluded) input and output to D's phase of the same step, as pix2pixHD computes the fake
  // once per iteration.
  std::vector<std::string> cached_keys_;
  torch::Tensor cached_input_, cached_fake_;
};

// ---- the trained net for inference ----
// A texture run's generator (a run folder or its checkpoint.safetensors), with its options from the checkpoint.
// InvalidInput naming the file when it is not a pix2pixhd-texture checkpoint.
struct TextureNet {
  TextureNetOptions options;
  nlohmann::json config;  // the run's whole configuration
  std::shared_ptr<torch::nn::Module> G;
  static TextureNet load(const std::string& run, torch::Device device);
  // Inputs per input map ([C, H, W] or [B, C, H, W], [0, 1], any size) → the four maps at options.res, [0, 1].
  std::map<std::string, torch::Tensor> infer(const std::map<std::string, torch::Tensor>& inputs) const;
};

train::TrainResult train_texture(const TrainRunOptions& run, TextureNetOptions model);

}  // namespace bareskin::texture
