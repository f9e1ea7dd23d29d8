// The texture maps both texture-inference networks work on (BareSkinNet §5): the generator's UV inputs and its four
// output maps, their stacking into tensors, the shared losses and helpers, and the run options of the two training
// commands (bareskin train texture / upscale). pix2pixHD lives in texture/pix2pixhd.h, SRGAN ×4 in upscale/srgan.h.
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "training/data.h"
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

// [B, C, H, W] to res² (area when shrinking, bilinear when growing).
torch::Tensor resize_to(const torch::Tensor& x, int64_t res);
// A (n + 1)/2-encoded normal map in [0, 1] brought back to unit length.
torch::Tensor renormalise_normals(const torch::Tensor& encoded01);
// One Adam optimizer over `params` as a single group "all".
train::OptimizerSpec adam(const std::string& name, std::vector<torch::Tensor> params, double lr, double beta1,
                          double beta2, const train::Schedule& schedule);
// A one-channel map repeated to three channels (three-channel maps unchanged).
torch::Tensor to3(const torch::Tensor& x);

// pix2pixHD's perceptual loss (its VGGLoss: Σ_l w_l · L1(φ_l(a), φ_l(b)), w = 1/32, 1/16, 1/8, 1/4, 1) on the VGG16
// trunk of training/vgg16.h — seeded random weights ("vgg16-random"), as no ImageNet weights ship here. Maps with
// one channel are repeated to three; a 3-channel map is one image. Inputs in [0, 1].
torch::Tensor vgg_loss(losses::Vgg16Features& vgg, const torch::Tensor& a, const torch::Tensor& b);

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
  void check() const;  // InvalidInput naming the flag
};

// The Trainer's options and config.json of a texture/upscale run.
train::TrainerOptions trainer_options(const TrainRunOptions& run, const nlohmann::json& model);
// The shard loader of `dataset` for a run (shuffled for training, in order for validation).
data::LoaderOptions loader(const std::string& dataset, const TrainRunOptions& run, std::vector<std::string> required,
                           bool shuffle);
// Decodes the first sample of a dataset, so bad data stops the command before the run folder exists.
data::Batch check_first_sample(const std::string& dataset, const TrainRunOptions& run,
                               const std::vector<std::string>& required);

// The checkpoint file of a run folder (or the file itself), and its metadata's task and configuration.
std::pair<std::string, nlohmann::json> checkpoint_config(const std::string& run);

}  // namespace bareskin::texture