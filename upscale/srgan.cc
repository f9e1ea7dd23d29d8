#include "upscale/srgan.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/json_options.h"
#include "core/png.h"
#include "core/shards.h"
#include "training/checkpoint.h"
#include "training/losses.h"
#include "training/nets/common.h"
#include "training/ssim.h"

namespace bareskin::texture {
namespace F = torch::nn::functional;

// ---- options ----

void UpscaleOptions::check() const {
  const std::string what = "upscale model";
  find_map(map);
  nets::require(phase == "l1" || phase == "gan", what, "phase must be l1 or gan", "pre-train with l1, then gan");
  nets::require(pixel_loss == "mse" || pixel_loss == "l1", what, "pixel_loss must be mse or l1",
                "use mse (SRGAN's SRResNet) or l1 (BasicSR)");
  nets::require(base == "bicubic" || base == "bilinear", what, "base must be bicubic or bilinear",
                "use bicubic (ours) or bilinear (BasicSR)");
  nets::require(patch == 128 || patch == 256, what, "patch must be 128 or 256",
                "the SRGAN discriminator's head takes 128² or 256²");
  nets::require(lr_decay >= 0 && lr_decay <= 1, what, "lr_decay must be a fraction of the steps in [0, 1]",
                "use 1 for a constant rate, 0.5 to decay over the second half");
  nets::require(clip_grad_norm >= 0 && std::isfinite(clip_grad_norm), what, "clip_grad_norm must be finite and >= 0",
                "0 is off, e.g. --clip-grad-norm 10");
}

namespace {
// The keys of UpscaleOptions, listed once (core/json_options.h).
const auto kUpscaleFields = [](auto& v, auto& o) {
  v("map", o.map);
  v("phase", o.phase);
  v("pixel_loss", o.pixel_loss);
  v("base", o.base);
  v("generator_options", o.generator_options);
  v("discriminator_options", o.discriminator_options);
  v("patch", o.patch);
  v("lambda_l1", o.lambda_l1);
  v("lambda_perceptual", o.lambda_perceptual);
  v("lambda_gan", o.lambda_gan);
  v("lr", o.lr);
  v("beta1", o.beta1);
  v("beta2", o.beta2);
  v.unless_default("lr_decay", o.lr_decay);
  v.unless_default("clip_grad_norm", o.clip_grad_norm);
};
}  // namespace

void to_json(nlohmann::json& j, const UpscaleOptions& o) { json_options::write(j, o, kUpscaleFields); }
void from_json(const nlohmann::json& j, UpscaleOptions& o) { json_options::read(j, o, "upscale model", kUpscaleFields); }

UpscaleOptions upscale_options_of_run(const nlohmann::json& model) {
  nlohmann::json j = model;
  // Runs written before these keys existed trained BasicSR's net (bilinear base) with L1.
  if (j.is_object() && !j.contains("pixel_loss")) j["pixel_loss"] = "l1";
  if (j.is_object() && !j.contains("base")) j["base"] = "bilinear";
  return j.get<UpscaleOptions>();
}

// ---- SRGAN ----

nets::MSRResNet make_upscaler(const UpscaleOptions& options) {
  nlohmann::json j = options.generator_options;
  const int channels = find_map(options.map).channels;
  j["num_in_ch"] = channels;
  j["num_out_ch"] = channels;
  j["upscale"] = 4;
  j["base"] = options.base;
  nets::MSRResNetOptions o;
  nets::from_json(j, o);
  return nets::MSRResNet(o);
}

namespace {

// The high-resolution member of a batch ("<map>_hr", else "<map>"), its channels, cropped to a multiple of 4.
std::pair<std::string, torch::Tensor> hr_member(const data::Batch& batch, const std::string& map) {
  const int channels = find_map(map).channels;
  auto it = batch.tensors.find(map + "_hr");
  if (it == batch.tensors.end()) it = batch.tensors.find(map);
  if (it == batch.tensors.end())
    throw InvalidInput("texture sample", "has neither '" + map + "_hr.png' nor '" + map + ".png'",
                       "make the dataset with --hr-res, or train on the 1K maps");
  auto hr = it->second.slice(1, 0, channels);
  return {it->first, hr.slice(2, 0, hr.size(2) / 4 * 4).slice(3, 0, hr.size(3) / 4 * 4)};
}

}  // namespace

std::pair<torch::Tensor, torch::Tensor> upscale_pair(const data::Batch& batch, const std::string& map, int64_t patch,
                                                     bool crop) {
  auto [name, hr] = hr_member(batch, map);
  const int64_t h = hr.size(2), w = hr.size(3);
  if (crop) {
    if (h < patch || w < patch)
      throw InvalidInput("texture sample member '" + name + ".png'",
                         "is " + std::to_string(w) + "² , smaller than the patch " + std::to_string(patch),
                         "use a smaller --patch or larger maps");
    std::vector<torch::Tensor> crops;
    for (int64_t b = 0; b < hr.size(0); ++b) {
      const int64_t y = torch::randint((h - patch) / 4 + 1, {1}, torch::kLong).item<int64_t>() * 4;
      const int64_t x = torch::randint((w - patch) / 4 + 1, {1}, torch::kLong).item<int64_t>() * 4;
      crops.push_back(hr.slice(0, b, b + 1).slice(2, y, y + patch).slice(3, x, x + patch));
    }
    hr = torch::cat(crops, 0);
  }
  hr = hr.contiguous();
  auto lr = F::avg_pool2d(hr, F::AvgPool2dFuncOptions(4));
  return {hr, lr};
}

torch::Tensor bicubic_x4(const torch::Tensor& lr, const std::string& map) {
  auto up = F::interpolate(lr, F::InterpolateFuncOptions()
                                   .scale_factor(std::vector<double>{4, 4})
                                   .mode(torch::kBicubic)
                                   .align_corners(false))
                .clamp_(0, 1);
  return map == "normal" ? renormalise_normals(up) : up;
}

namespace {

// `fn` on tiles of the low-resolution map with `margin` pixels of context, joined into one output `scale` times
// larger with `channels` channels: fn(y0, y1, x0, x1) returns the output of lr[y0:y1, x0:x1]. With `parallel`, the
// tiles are shared out over LibTorch's intra-op threads, each tile computed whole by one thread with one thread per
// operation inside (at::parallel_for does not nest), so the result does not depend on the thread count or schedule,
// and the threads do not meet at a barrier after every convolution of a small tile.
template <class Fn>
torch::Tensor tiled(const torch::Tensor& lr, int64_t tile, int64_t margin, int64_t scale, int64_t channels,
                    bool parallel, Fn fn) {
  const int64_t h = lr.size(2), w = lr.size(3), s = scale;
  const int64_t rows = (h + tile - 1) / tile, cols = (w + tile - 1) / tile;
  auto out = torch::empty({lr.size(0), channels, h * s, w * s}, lr.options());
  auto run = [&](int64_t begin, int64_t end) {
    c10::InferenceMode inference;  // thread-local: set in every worker
    for (int64_t i = begin; i < end; ++i) {
      const int64_t y = i / cols * tile, x = i % cols * tile;
      const int64_t y0 = std::max<int64_t>(0, y - margin), x0 = std::max<int64_t>(0, x - margin);
      const int64_t y1 = std::min(h, y + tile + margin), x1 = std::min(w, x + tile + margin);
      const torch::Tensor part = fn(y0, y1, x0, x1);
      const int64_t ty = std::min(tile, h - y), tx = std::min(tile, w - x);
      out.slice(2, y * s, (y + ty) * s)
          .slice(3, x * s, (x + tx) * s)
          .copy_(part.slice(2, (y - y0) * s, (y - y0 + ty) * s).slice(3, (x - x0) * s, (x - x0 + tx) * s));
    }
  };
  if (parallel && lr.device().is_cpu())
    at::parallel_for(0, rows * cols, 1, run);
  else
    run(0, rows * cols);
  return out;
}

// A tile's input in the layout the convolutions run fastest in on the CPU (channels last: mkldnn convolves it without
// reordering to its blocked layout and back around every convolution).
torch::Tensor conv_layout(const torch::Tensor& x) {
  return x.is_cpu() ? x.contiguous(at::MemoryFormat::ChannelsLast) : x;
}

}  // namespace

torch::Tensor upscale_x4(nets::MSRResNetImpl& net, const torch::Tensor& lr, const std::string& map, int64_t tile) {
  c10::InferenceMode inference;
  // Two passes, each in tiles with a margin of at least its reach, so the tiles join into exactly the untiled output
  // and no tensor grows past a few tens of MB (large tensors cost more in fresh pages than in arithmetic on this CPU):
  // the trunk (reach 1 + 2·num_block input pixels) in tiles of 2·`tile`, then the ×4 tail (reach 2: msrresnet.h)
  // in tiles of `tile`, reading the trunk's features once instead of recomputing them in every tile's margin. On the
  // CPU the tiles of each pass run in parallel, one thread per tile (tiled() above).
  const auto& o = net.options();
  const int64_t trunk_margin = 1 + 2 * int64_t(o.num_block), tail_margin = 2;
  const torch::Tensor features =
      tiled(lr, 2 * tile, trunk_margin, 1, o.num_feat, true, [&](auto y0, auto y1, auto x0, auto x1) {
        return net.features(conv_layout(lr.slice(2, y0, y1).slice(3, x0, x1)));
      });
  auto out = tiled(lr, tile, tail_margin, o.upscale, lr.size(1), true, [&](auto y0, auto y1, auto x0, auto x1) {
    return net.upsample(conv_layout(features.slice(2, y0, y1).slice(3, x0, x1)), lr.slice(2, y0, y1).slice(3, x0, x1));
  });
  out.clamp_(0, 1);
  return map == "normal" ? renormalise_normals(out) : out;
}

PatchSource::PatchSource(std::unique_ptr<data::DataSource> samples, std::string map, int64_t patch, int64_t batch,
                         int64_t pool, int64_t crops_per_map)
    : samples_(std::move(samples)), map_(std::move(map)), patch_(patch), batch_(batch),
      pool_(std::max<int64_t>(1, std::min(pool, samples_->epoch_size()))),
      crops_per_map_(std::max<int64_t>(1, crops_per_map)) {}

void PatchSource::seek(const data::Cursor& cursor) {
  samples_->seek(cursor);
  entries_.clear();
  crops_ = 0;
}

void PatchSource::refill() {
  // One new map per crops_per_map crops drawn, and the pool filled at the start.
  while (int64_t(entries_.size()) < pool_ || crops_ >= crops_per_map_) {
    if (int64_t(entries_.size()) >= pool_) {
      entries_.erase(entries_.begin());
      crops_ -= crops_per_map_;
    }
    data::Batch b = samples_->next();
    for (int64_t i = 0; i < b.size(); ++i) {
      data::Batch one;
      one.keys = {b.keys[i]};
      for (const auto& [name, t] : b.tensors) one.tensors[name] = t.slice(0, i, i + 1);  // views, no copies
      const torch::Tensor hr = hr_member(one, map_).second;
      if (hr.size(2) < patch_ || hr.size(3) < patch_)
        throw InvalidInput("texture sample '" + b.keys[i] + "'", "has a " + map_ + " map smaller than the patch " +
                                                                    std::to_string(patch_),
                           "use a smaller --patch or larger maps");
      entries_.push_back({b.keys[i], hr[0].contiguous()});
    }
  }
}

data::Batch PatchSource::next() {
  data::Batch out;
  std::vector<torch::Tensor> crops;
  for (int64_t k = 0; k < batch_; ++k) {
    refill();
    const int64_t i = torch::randint(int64_t(entries_.size()), {1}, torch::kLong).item<int64_t>();
    const torch::Tensor& m = entries_[i].map;
    const int64_t y = torch::randint((m.size(1) - patch_) / 4 + 1, {1}, torch::kLong).item<int64_t>() * 4;
    const int64_t x = torch::randint((m.size(2) - patch_) / 4 + 1, {1}, torch::kLong).item<int64_t>() * 4;
    crops.push_back(m.slice(1, y, y + patch_).slice(2, x, x + patch_));
    out.keys.push_back(entries_[i].key + "@" + std::to_string(y) + "," + std::to_string(x));
    out.meta.push_back(nlohmann::json::object());
    ++crops_;
  }
  out.tensors[map_ + "_hr"] = torch::stack(crops).contiguous();
  return out;
}

SrganTask::SrganTask(UpscaleOptions options, int64_t steps) : options_(std::move(options)), steps_(steps) {
  options_.check();
  G_ = make_upscaler(options_);
  if (options_.phase == "gan") {
    nlohmann::json j = options_.discriminator_options;
    j["num_in_ch"] = find_map(options_.map).channels;
    j["input_size"] = options_.patch;
    nets::VGGStyleDiscriminatorOptions o;
    nets::from_json(j, o);
    D_ = nets::VGGStyleDiscriminator(o);
    if (options_.lambda_perceptual > 0) vgg_ = losses::Vgg16Features();
  }
}

std::map<std::string, std::shared_ptr<torch::nn::Module>> SrganTask::modules() {
  if (options_.phase == "l1") return {{"G", G_.ptr()}};
  return {{"G", G_.ptr()}, {"D", D_.ptr()}};
}

std::vector<train::OptimizerSpec> SrganTask::optimizers() {
  const auto schedule = train::Schedule::linear_from(options_.lr_decay, steps_);
  std::vector<train::OptimizerSpec> out;
  out.push_back(adam("G", G_->parameters(), options_.lr, options_.beta1, options_.beta2, schedule));
  if (options_.phase == "gan")
    out.push_back(adam("D", D_->parameters(), options_.lr, options_.beta1, options_.beta2, schedule));
  return out;
}

train::Losses SrganTask::loss(size_t phase, const data::Batch& batch) {
  const auto device = G_->parameters().front().device();
  if (vgg_ && vgg_->parameters().front().device() != device) vgg_->to(device);
  if (phase == 0 || cached_keys_ != batch.keys) {
    auto [hr, lr] = upscale_pair(batch, options_.map, options_.patch, true);
    cached_hr_ = hr.to(device);
    cached_keys_ = batch.keys;
    cached_lr_ = lr.to(device);
  }
  if (phase == 0) {
    auto fake = G_->forward(cached_lr_);
    if (options_.phase == "l1") {
      if (options_.pixel_loss == "mse") return {{"mse", (fake - cached_hr_).pow(2).mean()}};
      return {{"l1", losses::l1(fake, cached_hr_)}};
    }
    train::Losses out;
    out["l1"] = options_.lambda_l1 * losses::l1(fake, cached_hr_);
    if (options_.lambda_perceptual > 0) out["vgg"] = options_.lambda_perceptual * vgg_loss(vgg_, fake, cached_hr_);
    out["gan"] = options_.lambda_gan * losses::gan_loss(D_->forward(fake), true, losses::GanKind::Vanilla, false);
    return out;
  }
  torch::Tensor fake;
  {
    torch::NoGradGuard no_grad;
    fake = G_->forward(cached_lr_);
  }
  return {{"real", losses::gan_loss(D_->forward(cached_hr_), true, losses::GanKind::Vanilla, true)},
          {"fake", losses::gan_loss(D_->forward(fake), false, losses::GanKind::Vanilla, true)}};
}

std::map<std::string, double> SrganTask::evaluate(const data::Batch& batch) {
  auto [hr, lr] = upscale_pair(batch, options_.map, options_.patch, false);
  auto sr = upscale_x4(*G_, lr.to(G_->parameters().front().device()), options_.map).cpu();
  return {{"psnr_srgan", losses::psnr(sr, hr).mean().item<double>()},
          {"psnr_bicubic", losses::psnr(bicubic_x4(lr, options_.map), hr).mean().item<double>()}};
}

std::vector<std::vector<torch::Tensor>> SrganTask::samples(const data::Batch& batch) {
  auto [hr, lr] = upscale_pair(batch, options_.map, options_.patch, false);
  hr = hr.slice(0, 0, 1);
  lr = lr.slice(0, 0, 1);
  auto sr = upscale_x4(*G_, lr.to(G_->parameters().front().device()), options_.map).cpu();
  return {{to3(bicubic_x4(lr, options_.map))[0], to3(sr)[0], to3(hr)[0]}};
}

// ---- loading the trained net ----

Upscaler Upscaler::load(const std::string& run, torch::Device device) {
  auto [path, meta] = checkpoint_config(run);
  const std::string task = meta.value("task", "");
  if (task.rfind("srgan-", 0) != 0)
    throw InvalidInput(path, "is a '" + task + "' checkpoint, not an upscaler",
                       "give runs of 'bareskin train upscale' as --upscale");
  Upscaler up;
  up.config = meta.at("config");
  up.options = upscale_options_of_run(up.config.at("model"));
  up.G = make_upscaler(up.options);
  train::load_module_weights(path, "G", *up.G);
  up.G->to(device);
  up.G->eval();
  return up;
}

torch::Tensor Upscaler::infer(const torch::Tensor& lr) const {
  const auto device = G->parameters().front().device();
  return upscale_x4(*G.ptr(), lr.to(device), options.map).cpu();
}

// ---- the training command ----

train::TrainResult train_upscale(const TrainRunOptions& run, UpscaleOptions model) {
  run.check();
  if (model.phase == "l1") {
    model.lambda_l1 = 1;
    if (!run.init.empty())
      throw InvalidInput("--init " + run.init, "is for the GAN phase", "pre-train with --phase l1 from scratch");
  }
  {
    auto first = check_first_sample(run.data, run, {model.map + ".png"});
    const auto& hr = first.tensors.count(model.map + "_hr") ? first.at(model.map + "_hr") : first.at(model.map);
    if (hr.size(2) < model.patch || hr.size(3) < model.patch)
      throw InvalidInput(run.data + ": " + first.keys[0] + "." + model.map + (first.tensors.count(model.map + "_hr") ? "_hr" : "") + ".png",
                         "is " + std::to_string(hr.size(3)) + " texels wide, smaller than the patch " + std::to_string(model.patch),
                         "use --patch 128 or larger maps");
  }
  TrainRunOptions one = run;
  one.batch = 1;
  // Only this map is decoded (the 4K one where the samples have it): the other members of a texture sample are ~4x
  // its size at 4K.
  auto map_loader = [&](const std::string& dataset, const TrainRunOptions& r, bool shuffle) {
    data::LoaderOptions o = loader(dataset, r, {model.map + ".png"}, shuffle);
    o.decode = {model.map + ".png", model.map + "_hr.png", "json"};
    return std::make_unique<data::ShardLoader>(o);
  };
  PatchSource train_data(map_loader(run.data, one, true), model.map, model.patch, run.batch, run.pool,
                         run.crops_per_map);
  std::unique_ptr<data::ShardLoader> val;
  if (!run.val.empty()) val = map_loader(run.val, run, false);
  train::seed_everything(run.seed);
  SrganTask task(model, run.steps);
  if (!run.init.empty() && !run.resume) {
    auto [path, meta] = checkpoint_config(run.init);
    if (meta.value("task", "") != task.name())
      throw InvalidInput(path, "is a '" + meta.value("task", std::string("?")) + "' checkpoint, not " + task.name(),
                         "give the L1 run of the same --map as --init");
    train::load_module_weights(path, "G", *task.generator());
  }
  train::Trainer trainer(trainer_options(run, model), task, train_data, val.get());
  return trainer.run();
}

}  // namespace bareskin::texture
