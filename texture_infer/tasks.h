// Texture inference (BareSkinNet §5): pix2pixHD from the UV inputs (unwrapped bare-skin image and its confidence,
// 3DMM albedo, 3DMM normal, 3DMM position) to the four maps (diffuse, normal, roughness, specular) at 1K, and SRGAN ×4
// (MSRResNet + VGG-style discriminator) from 1K to 4K per map type. Both are Tasks of training/trainer.h; the trained
// generators are loaded back for inference with TextureNet / Upscaler. docs/texture.md describes the method.
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "training/nets/msrresnet.h"
#include "training/nets/pix2pixhd.h"
#include "training/trainer.h"
#include "training/vgg16.h"

namespace bareskin::texture {

// One member of a texture sample ("<name>.png") and its channel count.
struct MapType {
  std::string name;
  int channels;
};
// The generator's inputs in stacking order: unwrap 3, confidence 1, mm_albedo 3, mm_normal 3, mm_position 3 (13).
const std::vector<MapType>& input_maps();
// The four outputs: diffuse 3, normal 3, roughness 1, specular 1 (8).
const std::vector<MapType>& output_maps();
int64_t total_channels(const std::vector<MapType>& maps);
const MapType& find_map(const std::string& name);  // InvalidInput listing the four outputs

// Each map of `maps` taken from `tensors` ([B, C, H, W] or [C, H, W] in [0, 1]), resized to res² (area when
// shrinking, bilinear when growing) and concatenated along the channels: [B, ΣC, res, res] in [0, 1].
torch::Tensor stack_maps(const std::map<std::string, torch::Tensor>& tensors, const std::vector<MapType>& maps,
                         int64_t res);
// The inverse of stack_maps for the outputs: [B, ΣC, H, W] in [0, 1] → per map; the normal map is renormalised as a
// vector ((n + 1)/2 encoding, unit length).
std::map<std::string, torch::Tensor> split_maps(const torch::Tensor& stacked, const std::vector<MapType>& maps);

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

// pix2pixHD's perceptual loss (its VGGLoss: Σ_l w_l · L1(φ_l(a), φ_l(b)), w = 1/32, 1/16, 1/8, 1/4, 1) on the VGG16
// trunk of training/vgg16.h — seeded random weights ("vgg16-random"), as no ImageNet weights ship here. Maps with
// one channel are repeated to three; a 3-channel map is one image. Inputs in [0, 1].
torch::Tensor vgg_loss(losses::Vgg16Features& vgg, const torch::Tensor& a, const torch::Tensor& b);

// ---- pix2pixHD ----
struct TextureNetOptions {
  std::string generator = "global";  // "global" (GlobalGenerator) | "local" (LocalEnhancer around it)
  nlohmann::json generator_options = nlohmann::json::object();      // zoo options over the defaults (ngf, ...)
  nlohmann::json discriminator_options = nlohmann::json::object();  // pix2pixhd_multiscale_d options
  int64_t res = 1024;             // the maps' side (multiple of 2^n_downsampling)
  double lambda_feat = 10;        // feature matching
  double lambda_perceptual = 10;  // VGG loss (pix2pixHD: λ_feat as well); 0 = off
  double lambda_l1 = 0;           // optional L1 to the targets (not in pix2pixHD; off by default)
  double lr = 2e-4, beta1 = 0.5, beta2 = 0.999;
  int64_t decay_start = -1;  // step where the linear decay starts (-1: half of the run, as niter = niter_decay)
  int64_t steps = 1000;      // the run's length (for the default decay start)
};
void to_json(nlohmann::json& j, const TextureNetOptions& o);
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
};
void to_json(nlohmann::json& j, const UpscaleOptions& o);
void from_json(const nlohmann::json& j, UpscaleOptions& o);

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
  explicit SrganTask(UpscaleOptions options);
  std::string name() const override { return "srgan-" + options_.map; }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override;
  std::vector<train::OptimizerSpec> optimizers() override;  // "G" (and "D" in the GAN phase)
  train::Losses loss(size_t phase, const data::Batch& batch) override;
  std::map<std::string, double> evaluate(const data::Batch& batch) override;  // PSNR of SRGAN and of bicubic
  std::vector<std::vector<torch::Tensor>> samples(const data::Batch& batch) override;
  nets::MSRResNet& generator() { return G_; }

 private:
  UpscaleOptions options_;
  nets::MSRResNet G_{nullptr};
  nets::VGGStyleDiscriminator D_{nullptr};
  losses::Vgg16Features vgg_{nullptr};
  std::vector<std::string> cached_keys_;
  torch::Tensor cached_hr_, cached_lr_;
};

// ---- the trained nets for inference ----
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
struct Upscaler {
  UpscaleOptions options;
  nlohmann::json config;
  nets::MSRResNet G{nullptr};
  static Upscaler load(const std::string& run, torch::Device device);
  torch::Tensor infer(const torch::Tensor& lr) const;  // [B, C, H, W] → ×4
};
// ---- the training commands (bareskin train texture / upscale) ----
struct TrainRunOptions {
  std::string data;    // texture shard set (folder with manifest.json or a .tar): the train split
  std::string val;     // optional validation split (PSNR per map in eval.csv, sample grids)
  std::string output;  // run folder
  std::string masks;   // optional masks/ shard set for the occlusion (texture only); synthetic occluders otherwise
  std::string init;    // upscale, GAN phase: the L1 run whose G starts it ("" = from scratch)
  int64_t pool = 8, crops_per_map = 64;  // upscale: PatchSource's pool of decoded maps and crops per map
  int64_t steps = 1000, batch = 1, log_every = 10, checkpoint_every = 500, eval_every = 500, sample_every = 500;
  uint64_t seed = 0;
  int decode_threads = 2;
  bool resume = false, progress = true;
  std::string device = "cpu";
  nlohmann::json extra = nlohmann::json::object();  // echoed into config.json (threads, ...)
};
train::TrainResult train_texture(const TrainRunOptions& run, TextureNetOptions model);
train::TrainResult train_upscale(const TrainRunOptions& run, UpscaleOptions model);

// The checkpoint file of a run folder (or the file itself), and its metadata's task and configuration.
std::pair<std::string, nlohmann::json> checkpoint_config(const std::string& run);

}  // namespace bareskin::texture
