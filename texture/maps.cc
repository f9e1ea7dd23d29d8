#include "texture/maps.h"

#include <filesystem>

#include "core/error.h"
#include "core/safetensors.h"
#include "training/checkpoint.h"
#include "training/ranks.h"

namespace bareskin::texture {
namespace fs = std::filesystem;
namespace F = torch::nn::functional;

const std::vector<MapType>& input_maps() {
  static const std::vector<MapType> maps = {
      {"unwrap", 3}, {"confidence", 1}, {"mm_albedo", 3}, {"mm_normal", 3}, {"mm_position", 3}};
  return maps;
}

const std::vector<MapType>& output_maps() {
  static const std::vector<MapType> maps = {{"diffuse", 3}, {"normal", 3}, {"roughness", 1}, {"specular", 1}};
  return maps;
}

int64_t total_channels(const std::vector<MapType>& maps) {
  int64_t n = 0;
  for (const auto& m : maps) n += m.channels;
  return n;
}

const MapType& find_map(const std::string& name) {
  for (const auto& m : output_maps())
    if (m.name == name) return m;
  throw InvalidInput("--map " + name, "is not a texture map", "use diffuse, normal, roughness or specular");
}

// [B, C, H, W] to res² (area when shrinking, bilinear when growing).
torch::Tensor resize_to(const torch::Tensor& x, int64_t res) {
  if (x.size(2) == res && x.size(3) == res) return x;
  if (x.size(2) >= res && x.size(3) >= res)
    return F::interpolate(x, F::InterpolateFuncOptions().size(std::vector<int64_t>{res, res}).mode(torch::kArea));
  return F::interpolate(
      x, F::InterpolateFuncOptions().size(std::vector<int64_t>{res, res}).mode(torch::kBilinear).align_corners(false));
}

torch::Tensor renormalise_normals(const torch::Tensor& encoded01) {
  const auto n = encoded01 * 2 - 1;
  // The length from the three channels' squares (Tensor::norm over the channel dimension is several times slower on
  // 4K maps); in place only where autograd keeps what it needs (division and sqrt read their inputs/result).
  const auto length = (n.slice(1, 0, 1).square() + n.slice(1, 1, 2).square() + n.slice(1, 2, 3).square())
                          .sqrt()
                          .clamp_min(1e-6);
  return (n / length).add_(1).mul_(0.5);
}

train::OptimizerSpec adam(const std::string& name, std::vector<torch::Tensor> params, double lr, double beta1,
                          double beta2, const train::Schedule& schedule) {
  train::OptimizerSpec spec;
  spec.name = name;
  spec.groups = {{"all", std::move(params), lr}};
  spec.beta1 = beta1;
  spec.beta2 = beta2;
  spec.schedule = schedule;
  return spec;
}

torch::Tensor to3(const torch::Tensor& x) { return x.size(1) == 3 ? x : x.slice(1, 0, 1).repeat({1, 3, 1, 1}); }

torch::Tensor stack_maps(const std::map<std::string, torch::Tensor>& tensors, const std::vector<MapType>& maps,
                         int64_t res) {
  std::vector<torch::Tensor> parts;
  for (const auto& m : maps) {
    auto it = tensors.find(m.name);
    if (it == tensors.end())
      throw InvalidInput("texture sample", "has no member '" + m.name + ".png'",
                         "texture shards need unwrap, confidence, mm_albedo, mm_normal, mm_position and the four maps");
    auto t = it->second.dim() == 3 ? it->second.unsqueeze(0) : it->second;
    if (t.size(1) < m.channels)
      throw InvalidInput("texture sample member '" + m.name + ".png'",
                         "has " + std::to_string(t.size(1)) + " channels, " + std::to_string(m.channels) + " needed",
                         "write it as " + std::string(m.channels == 1 ? "grey" : "RGB"));
    parts.push_back(resize_to(t.slice(1, 0, m.channels).to(torch::kFloat32), res));
  }
  return torch::cat(parts, 1);
}

std::map<std::string, torch::Tensor> split_maps(const torch::Tensor& stacked, const std::vector<MapType>& maps) {
  std::map<std::string, torch::Tensor> out;
  int64_t c = 0;
  for (const auto& m : maps) {
    auto x = stacked.slice(1, c, c + m.channels);
    out[m.name] = m.name == "normal" ? renormalise_normals(x) : x;
    c += m.channels;
  }
  return out;
}

torch::Tensor vgg_loss(losses::Vgg16Features& vgg, const torch::Tensor& a, const torch::Tensor& b) {
  static const double weights[] = {1.0 / 32, 1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0};
  auto fa = vgg->forward(to3(a));
  std::vector<torch::Tensor> fb;
  {
    torch::NoGradGuard no_grad;
    fb = vgg->forward(to3(b));
  }
  torch::Tensor total = torch::zeros({}, a.options());
  for (size_t l = 0; l < fa.size(); ++l) total = total + weights[l] * (fa[l] - fb[l]).abs().mean();
  return total;
}

std::pair<std::string, nlohmann::json> checkpoint_config(const std::string& run) {
  const std::string path = fs::is_directory(run) ? train::checkpoint_path(run) : run;
  const auto file = SafeTensors::open(path);
  auto it = file.metadata().find("bareskin.checkpoint");
  if (it == file.metadata().end())
    throw InvalidInput(path, "is not a training checkpoint", "give a run folder of 'bareskin train texture/upscale'");
  return {path, nlohmann::json::parse(it->second)};
}

void TrainRunOptions::check() const {
  if (data.empty()) throw InvalidInput("--data", "is missing", "give the texture shard set to train on");
  if (output.empty()) throw InvalidInput("-o", "names no run folder", "give the run's output folder");
  if (pool < 1 || crops_per_map < 1)
    throw InvalidInput("--pool/--crops-per-map", "must be at least 1", "e.g. --pool 8 --crops-per-map 64");
  train::check_intervals(steps, log_every, checkpoint_every, eval_every, sample_every);
  data::LoaderOptions loader;  // the batch and the decode threads, as the loader checks them
  loader.batch_size = batch;
  loader.decode_threads = decode_threads;
  loader.check();
  if (!extra.is_object()) throw InvalidInput("the run's extra configuration", "is not a JSON object", "");
}

train::TrainerOptions trainer_options(const TrainRunOptions& run, const nlohmann::json& model) {
  train::TrainerOptions o;
  o.run_dir = run.output;
  o.steps = run.steps;
  o.log_every = run.log_every;
  o.checkpoint_every = run.checkpoint_every;
  o.eval_every = run.val.empty() ? 0 : run.eval_every;
  o.sample_every = run.sample_every;
  o.resume = run.resume;
  o.progress = run.progress;
  o.device = torch::Device(run.device);
  o.clip_grad_norm = model.value("clip_grad_norm", 0.0);  // the model options' (0: off), as the config records it
  o.config = run.extra;
  o.config.update({{"data", run.data},         {"val", run.val},       {"masks", run.masks},
                   {"init", run.init},         {"steps", run.steps},   {"batch", run.batch},
                   {"pool", run.pool},         {"crops_per_map", run.crops_per_map},
                   {"seed", run.seed},         {"model", model},       {"log_every", run.log_every},
                   {"checkpoint_every", run.checkpoint_every},         {"eval_every", run.eval_every},
                   {"sample_every", run.sample_every},                 {"resume", run.resume},
                   {"progress", run.progress}, {"device", run.device}});
  // The profile records what was asked (its name, the flags given); what it set is compared as the options above, so
  // a run resumes with more steps, as `train recon` and `train bareskin` do.
  for (const char* key : {"device", "decode_threads", "profile"}) o.resumable_keys.push_back(key);
  return o;
}

data::LoaderOptions loader(const std::string& dataset, const TrainRunOptions& run, std::vector<std::string> required,
                           bool shuffle) {
  data::LoaderOptions o;
  o.dataset = dataset;
  o.required = std::move(required);
  o.batch_size = run.batch;
  o.seed = run.seed;
  o.shuffle_buffer = shuffle ? 64 : 0;
  o.decode_threads = run.decode_threads;
  return shuffle ? dist::this_rank(o) : o;  // validation: every rank reads the whole split
}

// Decodes the first sample of a dataset, so bad data stops the command before the run folder exists.
data::Batch check_first_sample(const std::string& dataset, const TrainRunOptions& run,
                               const std::vector<std::string>& required) {
  TrainRunOptions one = run;
  one.batch = 1;
  return data::ShardLoader(loader(dataset, one, required, false)).next();
}

}  // namespace bareskin::texture
