// SRGAN ×4 for the texture maps (BareSkinNet §5): MSRResNet + a VGG-style discriminator from 1K to 4K per map type,
// as a Task of training/trainer.h; the trained generator is loaded back for inference with Upscaler.
// docs/texture.md describes the method.
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "texture/maps.h"
#include "training/nets/msrresnet.h"
#include "training/trainer.h"
#include "training/vgg16.h"

namespace bareskin::texture {

// ---- SRGAN ×4 ----
struct UpscaleOptions {
  std::string map = "diffuse";  // which output map this upscaler is for (channels follow)
  std::string phase = "gan";    // "l1": MSRResNet pre-training with the pixel loss only; "gan": L1 + perceptual + adversarial
  std::string pixel_loss = "mse";  // the pre-training loss: "mse" (SRGAN's SRResNet) | "l1" (BasicSR's MSRResNet)
  std::string base = "bicubic";    // MSRResNet's output is a residual over this upsampling (ours; BasicSR: bilinear)
  nlohmann::json generator_options = nlohmann::json::object();  // msrresnet options (num_feat, num_block)
  nlohmann::json discriminator_options = nlohmann::json::object();  // srgan_d options (num_feat)
  int64_t patch = 128;          // high-resolution crop side (the discriminator's input size: 128 or 256)
  double lambda_l1 = 1e-2;      // pixel loss in the GAN phase (1 in the L1 phase)
  double lambda_perceptual = 1; // VGG loss (vgg16-random trunk); 0 = off
  double lambda_gan = 1e-3;     // SRGAN's adversarial weight
  double lr = 1e-4, beta1 = 0.9, beta2 = 0.999;
  double lr_decay = 1;          // the rate falls linearly to 0 from this fraction of the steps on (1: constant)
  double clip_grad_norm = 0;    // each step's gradients scaled to at most this norm (per network); 0: off
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const UpscaleOptions& o);
void from_json(const nlohmann::json& j, UpscaleOptions& o);  // InvalidInput: unknown key, wrong type, bad value
// The options of a trained run (its config.json's "model"): a run written before pixel_loss and base existed trained
// BasicSR's net (l1, bilinear), which the struct's defaults no longer are.
UpscaleOptions upscale_options_of_run(const nlohmann::json& model);

nets::MSRResNet make_upscaler(const UpscaleOptions& options);

// SRGAN's training crops from few decoded maps: decoding a texture sample (every member, the 4K maps included) costs
// far more than a step on a crop, so each decoded "<map>_hr" (else "<map>") map stays in a pool of `pool` maps and
// serves `crops_per_map` random crops (positions on the 4-texel grid) before the oldest is replaced by the loader's
// next sample. Batches hold tensors["<map>_hr"] of [batch, C, patch, patch] and keys "<sample>@<y>,<x>". The crop
// draws use LibTorch's default generator; a resumed run continues from the loader's position with a fresh pool.
class PatchSource : public data::DataSource {
 public:
  PatchSource(std::unique_ptr<data::DataSource> samples, std::string map, int64_t patch, int64_t batch,
              int64_t pool = 8, int64_t crops_per_map = 64);
  data::Batch next() override;
  data::Cursor cursor() const override { return samples_->cursor(); }
  void seek(const data::Cursor& cursor) override;
  int64_t epoch_size() const override { return samples_->epoch_size(); }

 private:
  struct Entry {
    std::string key;
    torch::Tensor map;  // [C, H, W]
  };
  void refill();
  std::unique_ptr<data::DataSource> samples_;
  std::string map_;
  int64_t patch_, batch_, pool_, crops_per_map_, crops_ = 0;
  std::vector<Entry> entries_;
};

// The ×4 pair of a batch: random aligned crops of "<map>_hr" (patch²) and their 4×4 box-filtered low-resolution
// versions, both in [0, 1]. With `crop` false, the whole maps.
std::pair<torch::Tensor, torch::Tensor> upscale_pair(const data::Batch& batch, const std::string& map, int64_t patch,
                                                     bool crop);
// Bicubic ×4 (the baseline), clamped to [0, 1]; normals renormalised.
torch::Tensor bicubic_x4(const torch::Tensor& lr, const std::string& map);
// MSRResNet ×4 of a [0, 1] map, clamped, normals renormalised: the trunk and then the ×4 tail in tiles (`tile`
// input pixels for the tail, 2× that for the trunk) whose margins cover each pass's reach, so the result is the
// untiled net's and no tensor grows past a few tens of MB. On the CPU each pass's tiles run in parallel, one intra-op
// thread per tile (deterministic: a tile is computed whole by one thread), in the channels-last layout. Runs in
// inference mode.
torch::Tensor upscale_x4(nets::MSRResNetImpl& net, const torch::Tensor& lr, const std::string& map, int64_t tile = 128);

class SrganTask : public train::Task {
 public:
  // `steps`: the run's length, which places the learning-rate decay (UpscaleOptions::lr_decay).
  SrganTask(UpscaleOptions options, int64_t steps);
  std::string name() const override { return "srgan-" + options_.map; }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override;
  std::vector<train::OptimizerSpec> optimizers() override;  // "G" (and "D" in the GAN phase)
  train::Losses loss(size_t phase, const data::Batch& batch) override;
  std::map<std::string, double> evaluate(const data::Batch& batch) override;  // PSNR of SRGAN and of bicubic
  std::vector<std::vector<torch::Tensor>> samples(const data::Batch& batch) override;
  nets::MSRResNet& generator() { return G_; }

 private:
  UpscaleOptions options_;
  int64_t steps_;
  nets::MSRResNet G_{nullptr};
  nets::VGGStyleDiscriminator D_{nullptr};
  losses::Vgg16Features vgg_{nullptr};
  std::vector<std::string> cached_keys_;
  torch::Tensor cached_hr_, cached_lr_;
};

// ---- the trained net for inference ----
struct Upscaler {
  UpscaleOptions options;
  nlohmann::json config;
  nets::MSRResNet G{nullptr};
  static Upscaler load(const std::string& run, torch::Device device);
  torch::Tensor infer(const torch::Tensor& lr) const;  // [B, C, H, W] → ×4
};

train::TrainResult train_upscale(const TrainRunOptions& run, UpscaleOptions model);

}  // namespace bareskin::texture
