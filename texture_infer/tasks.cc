#include "texture_infer/tasks.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/png.h"
#include "core/safetensors.h"
#include "texgen/shards.h"
#include "training/checkpoint.h"
#include "training/losses.h"
#include "training/nets/common.h"
#include "training/ssim.h"

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

namespace {

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

}  // namespace

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

// ---- occlusion ----

OcclusionSampler::OcclusionSampler(torch::Tensor masks) : masks_(std::move(masks)) {}

OcclusionSampler OcclusionSampler::from_shards(const std::string& dataset, int64_t res, int64_t max_masks) {
  const auto manifest = shards::open_dataset(dataset);
  std::vector<torch::Tensor> masks;
  for (const auto& info : manifest.shards) {
    shards::ShardReader reader(shards::shard_path(dataset, info));
    shards::Sample sample;
    while (int64_t(masks.size()) < max_masks && reader.next(sample)) {
      auto it = sample.members.find("mask.png");
      if (it == sample.members.end())
        throw InvalidInput(dataset + ": sample " + sample.key, "has no mask.png", "give a masks/ shard set (prefix mask)");
      const Image image = decode_png(it->second, dataset + ": " + sample.key + ".mask.png");
      auto t = torch::from_blob(const_cast<float*>(image.pixels.data()), {1, image.height, image.width, image.channels},
                                torch::kFloat32)
                   .permute({0, 3, 1, 2})
                   .slice(1, 0, 1)
                   .clone(torch::MemoryFormat::Contiguous);  // `image` dies at the end of this iteration
      masks.push_back(resize_to(t, res));
    }
  }
  if (masks.empty()) throw InvalidInput(dataset, "holds no occlusion masks", "give a masks/ shard set with samples");
  return OcclusionSampler(torch::cat(masks, 0));
}

torch::Tensor OcclusionSampler::sample(int64_t batch, int64_t res) const {
  if (masks_.defined()) {
    auto index = torch::randint(masks_.size(0), {batch}, torch::kLong);
    auto m = resize_to(masks_.index_select(0, index), res);
    // A random horizontal flip doubles the variety (faces are near-symmetric in the template UV).
    auto flip = (torch::rand({batch, 1, 1, 1}) < 0.5).to(torch::kFloat32);
    return flip * m.flip({3}) + (1 - flip) * m;
  }
  // Synthetic: 1–3 occluders per sample, each an ellipse (hand, glasses lens) or a half-plane cut from an edge (hair,
  // a turned-away side), in UV coordinates u, v ∈ [0, 1].
  auto lin = torch::linspace(0.5 / double(res), 1 - 0.5 / double(res), res);
  auto v = lin.view({1, res, 1}).expand({1, res, res});
  auto u = lin.view({1, 1, res}).expand({1, res, res});
  std::vector<torch::Tensor> out;
  for (int64_t b = 0; b < batch; ++b) {
    auto mask = torch::ones({1, res, res});
    const int64_t count = 1 + torch::randint(3, {1}, torch::kLong).item<int64_t>();
    for (int64_t k = 0; k < count; ++k) {
      auto r = torch::rand({6});
      auto a = r.accessor<float, 1>();
      torch::Tensor inside;
      if (a[0] < 0.5) {
        const double cu = 0.15 + 0.7 * a[1], cv = 0.15 + 0.7 * a[2], ru = 0.05 + 0.2 * a[3], rv = 0.05 + 0.2 * a[4];
        inside = ((u - cu) / ru).pow(2) + ((v - cv) / rv).pow(2) < 1;
      } else {
        const double angle = 2 * M_PI * a[1], t = 0.15 + 0.3 * a[2];
        inside = (u - 0.5) * std::cos(angle) + (v - 0.5) * std::sin(angle) > t;
      }
      mask = mask * (1 - inside.to(torch::kFloat32));
    }
    out.push_back(mask.unsqueeze(0));
  }
  return torch::cat(out, 0);
}

torch::Tensor occlude(const torch::Tensor& inputs01, const torch::Tensor& mask) {
  return torch::cat({inputs01.slice(1, 0, 4) * mask, inputs01.slice(1, 4)}, 1);
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

namespace {
torch::Tensor perceptual_all(losses::Vgg16Features& vgg, const torch::Tensor& fake01, const torch::Tensor& real01) {
  auto f = split_maps(fake01, output_maps());
  auto r = split_maps(real01, output_maps());
  torch::Tensor total = torch::zeros({}, fake01.options());
  // The raw (not renormalised) normal channels carry the gradient.
  int64_t c = 0;
  for (const auto& m : output_maps()) {
    total = total + vgg_loss(vgg, fake01.slice(1, c, c + m.channels), real01.slice(1, c, c + m.channels));
    c += m.channels;
  }
  return total;
}
}  // namespace

// ---- options ----

void to_json(nlohmann::json& j, const TextureNetOptions& o) {
  j = {{"generator", o.generator},
       {"generator_options", o.generator_options},
       {"discriminator_options", o.discriminator_options},
       {"res", o.res},
       {"lambda_feat", o.lambda_feat},
       {"lambda_perceptual", o.lambda_perceptual},
       {"lambda_l1", o.lambda_l1},
       {"lr", o.lr},
       {"beta1", o.beta1},
       {"beta2", o.beta2},
       {"decay_start", o.decay_start},
       {"steps", o.steps}};
}

void from_json(const nlohmann::json& j, TextureNetOptions& o) {
  const std::string what = "texture model";
  nets::check_keys(j, what,
                   {"generator", "generator_options", "discriminator_options", "res", "lambda_feat",
                    "lambda_perceptual", "lambda_l1", "lr", "beta1", "beta2", "decay_start", "steps"});
  nets::read_key(j, what, "generator", o.generator);
  if (j.contains("generator_options")) o.generator_options = j.at("generator_options");
  if (j.contains("discriminator_options")) o.discriminator_options = j.at("discriminator_options");
  nets::read_key(j, what, "res", o.res);
  nets::read_key(j, what, "lambda_feat", o.lambda_feat);
  nets::read_key(j, what, "lambda_perceptual", o.lambda_perceptual);
  nets::read_key(j, what, "lambda_l1", o.lambda_l1);
  nets::read_key(j, what, "lr", o.lr);
  nets::read_key(j, what, "beta1", o.beta1);
  nets::read_key(j, what, "beta2", o.beta2);
  nets::read_key(j, what, "decay_start", o.decay_start);
  nets::read_key(j, what, "steps", o.steps);
  nets::require(o.generator == "global" || o.generator == "local", what, "generator must be global or local",
                "e.g. \"generator\": \"global\"");
  nets::require(o.res >= 16, what, "res must be at least 16", "e.g. --res 1024");
}

void to_json(nlohmann::json& j, const UpscaleOptions& o) {
  j = {{"map", o.map},
       {"phase", o.phase},
       {"pixel_loss", o.pixel_loss},
       {"base", o.base},
       {"generator_options", o.generator_options},
       {"discriminator_options", o.discriminator_options},
       {"patch", o.patch},
       {"lambda_l1", o.lambda_l1},
       {"lambda_perceptual", o.lambda_perceptual},
       {"lambda_gan", o.lambda_gan},
       {"lr", o.lr},
       {"beta1", o.beta1},
       {"beta2", o.beta2}};
}

void from_json(const nlohmann::json& j, UpscaleOptions& o) {
  const std::string what = "upscale model";
  nets::check_keys(j, what,
                   {"map", "phase", "pixel_loss", "base", "generator_options", "discriminator_options", "patch",
                    "lambda_l1", "lambda_perceptual", "lambda_gan", "lr", "beta1", "beta2"});
  nets::read_key(j, what, "map", o.map);
  nets::read_key(j, what, "phase", o.phase);
  // Runs written before these keys existed trained BasicSR's net (bilinear base) with L1.
  o.pixel_loss = j.contains("pixel_loss") ? j.at("pixel_loss").get<std::string>() : "l1";
  o.base = j.contains("base") ? j.at("base").get<std::string>() : "bilinear";
  if (j.contains("generator_options")) o.generator_options = j.at("generator_options");
  if (j.contains("discriminator_options")) o.discriminator_options = j.at("discriminator_options");
  nets::read_key(j, what, "patch", o.patch);
  nets::read_key(j, what, "lambda_l1", o.lambda_l1);
  nets::read_key(j, what, "lambda_perceptual", o.lambda_perceptual);
  nets::read_key(j, what, "lambda_gan", o.lambda_gan);
  nets::read_key(j, what, "lr", o.lr);
  nets::read_key(j, what, "beta1", o.beta1);
  nets::read_key(j, what, "beta2", o.beta2);
  find_map(o.map);
  nets::require(o.phase == "l1" || o.phase == "gan", what, "phase must be l1 or gan", "pre-train with l1, then gan");
  nets::require(o.pixel_loss == "mse" || o.pixel_loss == "l1", what, "pixel_loss must be mse or l1",
                "use mse (SRGAN's SRResNet) or l1 (BasicSR)");
  nets::require(o.base == "bicubic" || o.base == "bilinear", what, "base must be bicubic or bilinear",
                "use bicubic (ours) or bilinear (BasicSR)");
  nets::require(o.patch == 128 || o.patch == 256, what, "patch must be 128 or 256",
                "the SRGAN discriminator's head takes 128² or 256²");
}

// ---- pix2pixHD ----

std::shared_ptr<torch::nn::Module> make_texture_generator(const TextureNetOptions& options) {
  nlohmann::json j = options.generator_options;
  j["in_channels"] = total_channels(input_maps());
  j["out_channels"] = total_channels(output_maps());
  if (options.generator == "local") {
    nets::LocalEnhancerOptions o;
    nets::from_json(j, o);
    return nets::LocalEnhancer(o).ptr();
  }
  nets::GlobalGeneratorOptions o;
  nets::from_json(j, o);
  const int64_t multiple = int64_t(1) << o.n_downsampling;
  nets::require(options.res % multiple == 0, "texture model",
                "res " + std::to_string(options.res) + " is not a multiple of 2^n_downsampling = " +
                    std::to_string(multiple),
                "pick --res as a multiple of " + std::to_string(multiple));
  return nets::GlobalGenerator(o).ptr();
}

torch::Tensor run_generator(torch::nn::Module& generator, const torch::Tensor& x) {
  if (auto* g = dynamic_cast<nets::GlobalGeneratorImpl*>(&generator)) return g->forward(x);
  if (auto* l = dynamic_cast<nets::LocalEnhancerImpl*>(&generator)) return l->forward(x);
  BS_CHECK(false, "not a texture generator");
  return {};
}

Pix2PixHDTask::Pix2PixHDTask(TextureNetOptions options, OcclusionSampler occlusion)
    : options_(std::move(options)), occlusion_(std::move(occlusion)) {
  G_ = make_texture_generator(options_);
  nets::MultiscaleDiscriminatorOptions d;
  nlohmann::json dj = options_.discriminator_options;
  dj["in_channels"] = total_channels(input_maps()) + total_channels(output_maps());
  nets::from_json(dj, d);
  d.get_interm_feat = true;
  D_ = nets::MultiscaleDiscriminator(d);
  if (options_.lambda_perceptual > 0) vgg_ = losses::Vgg16Features();
}

std::map<std::string, std::shared_ptr<torch::nn::Module>> Pix2PixHDTask::modules() {
  return {{"G", G_}, {"D", D_.ptr()}};
}

std::vector<train::OptimizerSpec> Pix2PixHDTask::optimizers() {
  train::Schedule schedule;
  schedule.kind = "linear";
  schedule.decay_start = options_.decay_start >= 0 ? options_.decay_start : options_.steps / 2;
  return {adam("G", G_->parameters(), options_.lr, options_.beta1, options_.beta2, schedule),
          adam("D", D_->parameters(), options_.lr, options_.beta1, options_.beta2, schedule)};
}

torch::Tensor Pix2PixHDTask::input(const data::Batch& batch, const torch::Tensor& mask) const {
  auto x = stack_maps(batch.tensors, input_maps(), options_.res);
  if (mask.defined()) x = occlude(x, mask.to(x.device()));
  return x * 2 - 1;
}

torch::Tensor Pix2PixHDTask::target(const data::Batch& batch) const {
  return stack_maps(batch.tensors, output_maps(), options_.res) * 2 - 1;
}

train::Losses Pix2PixHDTask::loss(size_t phase, const data::Batch& batch) {
  const auto device = G_->parameters().front().device();
  if (vgg_ && vgg_->parameters().front().device() != device) vgg_->to(device);
  auto real = target(batch).to(device);
  if (phase == 0 || cached_keys_ != batch.keys) {
    auto mask = occlusion_.sample(batch.size(), options_.res);
    cached_input_ = input(batch, mask).to(device);
    cached_keys_ = batch.keys;
    if (phase != 0) {
      torch::NoGradGuard no_grad;
      cached_fake_ = run_generator(*G_, cached_input_);
    }
  }
  const auto& in = cached_input_;
  if (phase == 0) {
    auto fake = run_generator(*G_, in);
    cached_fake_ = fake.detach();
    auto pred_fake = D_->forward(torch::cat({in, fake}, 1));
    losses::MultiscaleOutputs pred_real;
    {
      torch::NoGradGuard no_grad;
      pred_real = D_->forward(torch::cat({in, real}, 1));
    }
    train::Losses out;
    out["gan"] = losses::gan_loss(pred_fake, true, losses::GanKind::Lsgan, false);
    out["feat"] = losses::feature_matching(pred_fake, pred_real, options_.lambda_feat);
    if (options_.lambda_perceptual > 0)
      out["vgg"] = options_.lambda_perceptual * perceptual_all(vgg_, (fake + 1) * 0.5, (real + 1) * 0.5);
    if (options_.lambda_l1 > 0) out["l1"] = options_.lambda_l1 * losses::l1(fake, real);
    return out;
  }
  auto pred_fake = D_->forward(torch::cat({in, cached_fake_}, 1));
  auto pred_real = D_->forward(torch::cat({in, real}, 1));
  return {{"fake", 0.5 * losses::gan_loss(pred_fake, false, losses::GanKind::Lsgan, true)},
          {"real", 0.5 * losses::gan_loss(pred_real, true, losses::GanKind::Lsgan, true)}};
}

std::map<std::string, double> Pix2PixHDTask::evaluate(const data::Batch& batch) {
  const auto device = G_->parameters().front().device();
  auto fake = ((run_generator(*G_, input(batch).to(device)) + 1) * 0.5).clamp(0, 1);
  auto real = (target(batch).to(device) + 1) * 0.5;
  auto f = split_maps(fake, output_maps());
  auto r = split_maps(real, output_maps());
  std::map<std::string, double> out;
  for (const auto& m : output_maps()) out["psnr_" + m.name] = losses::psnr(f[m.name], r[m.name]).mean().item<double>();
  return out;
}

std::vector<std::vector<torch::Tensor>> Pix2PixHDTask::samples(const data::Batch& batch) {
  const auto device = G_->parameters().front().device();
  auto in = (input(batch).to(device) + 1) * 0.5;
  auto fake = ((run_generator(*G_, input(batch).to(device)) + 1) * 0.5).clamp(0, 1);
  auto f = split_maps(fake, output_maps());
  auto r = split_maps((target(batch).to(device) + 1) * 0.5, output_maps());
  auto ins = split_maps(in, input_maps());
  auto one = [](const torch::Tensor& t) { return to3(t.slice(0, 0, 1)).squeeze(0).cpu(); };
  return {{one(ins["unwrap"]), one(ins["mm_albedo"]), one(f["diffuse"]), one(r["diffuse"])},
          {one(ins["confidence"]), one(ins["mm_normal"]), one(f["normal"]), one(r["normal"])},
          {one(f["roughness"]), one(r["roughness"]), one(f["specular"]), one(r["specular"])}};
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

SrganTask::SrganTask(UpscaleOptions options) : options_(std::move(options)) {
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
  std::vector<train::OptimizerSpec> out;
  out.push_back(adam("G", G_->parameters(), options_.lr, options_.beta1, options_.beta2, {}));
  if (options_.phase == "gan") out.push_back(adam("D", D_->parameters(), options_.lr, options_.beta1, options_.beta2, {}));
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

// ---- loading trained nets ----

std::pair<std::string, nlohmann::json> checkpoint_config(const std::string& run) {
  const std::string path = fs::is_directory(run) ? train::checkpoint_path(run) : run;
  const auto file = SafeTensors::open(path);
  auto it = file.metadata().find("bareskin.checkpoint");
  if (it == file.metadata().end())
    throw InvalidInput(path, "is not a training checkpoint", "give a run folder of 'bareskin train texture/upscale'");
  return {path, nlohmann::json::parse(it->second)};
}

TextureNet TextureNet::load(const std::string& run, torch::Device device) {
  auto [path, meta] = checkpoint_config(run);
  if (meta.value("task", "") != "pix2pixhd-texture")
    throw InvalidInput(path, "is a '" + meta.value("task", std::string("?")) + "' checkpoint, not a texture model",
                       "give the run of 'bareskin train texture' as --texture");
  TextureNet net;
  net.config = meta.at("config");
  net.options = net.config.at("model").get<TextureNetOptions>();
  net.G = make_texture_generator(net.options);
  train::load_module_weights(path, "G", *net.G);
  net.G->to(device);
  net.G->eval();
  return net;
}

std::map<std::string, torch::Tensor> TextureNet::infer(const std::map<std::string, torch::Tensor>& inputs) const {
  c10::InferenceMode inference;
  const auto device = G->parameters().front().device();
  auto x = stack_maps(inputs, input_maps(), options.res).to(device) * 2 - 1;
  auto y = ((run_generator(*G, x) + 1) * 0.5).clamp(0, 1).cpu();
  return split_maps(y, output_maps());
}

Upscaler Upscaler::load(const std::string& run, torch::Device device) {
  auto [path, meta] = checkpoint_config(run);
  const std::string task = meta.value("task", "");
  if (task.rfind("srgan-", 0) != 0)
    throw InvalidInput(path, "is a '" + task + "' checkpoint, not an upscaler",
                       "give runs of 'bareskin train upscale' as --upscale");
  Upscaler up;
  up.config = meta.at("config");
  up.options = up.config.at("model").get<UpscaleOptions>();
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

// ---- training commands ----

namespace {

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
  o.config = run.extra;
  o.config.update({{"data", run.data},         {"val", run.val},       {"masks", run.masks},
                   {"init", run.init},         {"steps", run.steps},   {"batch", run.batch},
                   {"pool", run.pool},         {"crops_per_map", run.crops_per_map},
                   {"seed", run.seed},         {"model", model},       {"log_every", run.log_every},
                   {"checkpoint_every", run.checkpoint_every},         {"eval_every", run.eval_every},
                   {"sample_every", run.sample_every},                 {"resume", run.resume},
                   {"progress", run.progress}, {"device", run.device}});
  o.resumable_keys.push_back("device");
  o.resumable_keys.push_back("decode_threads");
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
  return o;
}

// Decodes the first sample of a dataset, so bad data stops the command before the run folder exists.
data::Batch check_first_sample(const std::string& dataset, const TrainRunOptions& run,
                               const std::vector<std::string>& required) {
  TrainRunOptions one = run;
  one.batch = 1;
  return data::ShardLoader(loader(dataset, one, required, false)).next();
}

}  // namespace

train::TrainResult train_texture(const TrainRunOptions& run, TextureNetOptions model) {
  model.steps = run.steps;
  std::vector<std::string> required;
  for (const auto* maps : {&input_maps(), &output_maps()})
    for (const auto& m : *maps) required.push_back(m.name + ".png");
  check_first_sample(run.data, run, required);
  if (!run.val.empty()) check_first_sample(run.val, run, required);
  data::ShardLoader train_data(loader(run.data, run, required, true));
  std::unique_ptr<data::ShardLoader> val;
  if (!run.val.empty()) val = std::make_unique<data::ShardLoader>(loader(run.val, run, required, false));
  train::seed_everything(run.seed);
  OcclusionSampler occlusion = run.masks.empty() ? OcclusionSampler() : OcclusionSampler::from_shards(run.masks, model.res);
  Pix2PixHDTask task(model, std::move(occlusion));
  train::Trainer trainer(trainer_options(run, model), task, train_data, val.get());
  return trainer.run();
}

train::TrainResult train_upscale(const TrainRunOptions& run, UpscaleOptions model) {
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
  PatchSource train_data(std::make_unique<data::ShardLoader>(loader(run.data, one, {model.map + ".png"}, true)),
                         model.map, model.patch, run.batch, run.pool, run.crops_per_map);
  std::unique_ptr<data::ShardLoader> val;
  if (!run.val.empty()) val = std::make_unique<data::ShardLoader>(loader(run.val, run, {model.map + ".png"}, false));
  train::seed_everything(run.seed);
  SrganTask task(model);
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
