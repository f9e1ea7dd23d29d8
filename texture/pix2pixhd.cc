#include "texture/pix2pixhd.h"

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
#include "texture/uvnet.h"

namespace bareskin::texture {
namespace F = torch::nn::functional;

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

void TextureNetOptions::check() const {
  const std::string what = "texture model";
  nets::require(generator == "global" || generator == "local" || generator == "uv", what,
                "generator must be global, local or uv", "e.g. \"generator\": \"global\"");
  nets::require(res >= 16, what, "res must be at least 16", "e.g. --res 1024");
  nets::require(lambda_gan >= 0 && lambda_feat >= 0 && lambda_perceptual >= 0 && lambda_l1 >= 0, what,
                "the loss weights must not be negative", "e.g. --lambda-l1 10");
  nets::require(lambda_gan + lambda_feat + lambda_perceptual + lambda_l1 > 0, what, "every loss weight is 0",
                "give at least one, e.g. --lambda-l1 10");
  nets::require(lr_decay >= 0 && lr_decay <= 1, what, "lr_decay must be a fraction of the steps in [0, 1]",
                "e.g. --lr-decay 0.5");
  nets::require(clip_grad_norm >= 0 && std::isfinite(clip_grad_norm), what, "clip_grad_norm must be finite and >= 0",
                "0 is off, e.g. --clip-grad-norm 1");
}

namespace {
// The keys of TextureNetOptions, listed once (core/json_options.h).
const auto kTextureFields = [](auto& v, auto& o) {
  v("generator", o.generator);
  v("generator_options", o.generator_options);
  v("discriminator_options", o.discriminator_options);
  v("res", o.res);
  v("lambda_gan", o.lambda_gan);
  v("lambda_feat", o.lambda_feat);
  v("lambda_perceptual", o.lambda_perceptual);
  v("lambda_l1", o.lambda_l1);
  v("lr", o.lr);
  v("beta1", o.beta1);
  v("beta2", o.beta2);
  v("lr_decay", o.lr_decay);
  v("clip_grad_norm", o.clip_grad_norm);
  v("steps", o.steps);
};
}  // namespace

void to_json(nlohmann::json& j, const TextureNetOptions& o) { json_options::write(j, o, kTextureFields); }
void from_json(const nlohmann::json& j, TextureNetOptions& o) {
  if (!j.is_object() || !j.contains("decay_start"))
    return json_options::read(j, o, "texture model", kTextureFields);
  // A run from before lr_decay: its decay's first step as a fraction of its steps. Its default, -1 (half the run), is
  // today's default, 0.5, so such a run resumes with the flags it was started with (with an odd number of steps the
  // decay now starts one step later: 0.5 × steps is rounded up, where the step was rounded down).
  nlohmann::json current = j;
  const auto start = current["decay_start"];
  current.erase("decay_start");
  if (!start.is_number_integer() || current.contains("lr_decay"))
    throw InvalidInput("texture model", "has a decay_start that is not a whole step, or both it and lr_decay",
                       "give lr_decay alone, e.g. \"lr_decay\": 0.5");
  const int64_t steps = std::max<int64_t>(1, current.value("steps", o.steps));
  const int64_t step = start.get<int64_t>();
  current["lr_decay"] = step < 0 ? 0.5 : double(std::min(step, steps)) / double(steps);
  json_options::read(current, o, "texture model", kTextureFields);
}

torch::Tensor uv_layout(const torch::Tensor& inputs) {
  const int64_t normal = 7;  // unwrap 3, confidence 1, mm_albedo 3, then mm_normal (input_maps())
  return (inputs.narrow(1, normal, 3) > -1).any(1, true).to(inputs.dtype());
}

torch::Tensor mm_only_maps(const torch::Tensor& inputs, const torch::Tensor& truth01, const torch::Tensor& layout) {
  const int64_t albedo = 4;  // unwrap 3, confidence 1, then mm_albedo (input_maps())
  auto diffuse = (inputs.narrow(1, albedo, 3) + 1) * 0.5;
  auto normal = torch::zeros_like(diffuse);
  normal.narrow(1, 0, 2).fill_(0.5);
  normal.narrow(1, 2, 1).fill_(1);
  auto grey = truth01.narrow(1, 6, 2);
  auto constants = ((grey * layout).sum({2, 3}, true) / layout.sum({2, 3}, true).clamp_min(1)).expand_as(grey);
  return torch::cat({diffuse, normal, constants}, 1);
}

// ---- pix2pixHD ----

std::shared_ptr<torch::nn::Module> make_texture_generator(const TextureNetOptions& options) {
  if (options.generator == "uv") return UVNet(options.generator_options, options.res).ptr();
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
  if (auto* u = dynamic_cast<UVNetImpl*>(&generator)) return u->forward(x);
  BS_CHECK(false, "not a texture generator");
  return {};
}

Pix2PixHDTask::Pix2PixHDTask(TextureNetOptions options, OcclusionSampler occlusion)
    : options_(std::move(options)), occlusion_(std::move(occlusion)) {
  options_.check();
  G_ = make_texture_generator(options_);
  if (adversarial()) make_discriminator();
  if (options_.lambda_perceptual > 0) vgg_ = losses::Vgg16Features();
}

bool Pix2PixHDTask::adversarial() const { return options_.lambda_gan > 0 || options_.lambda_feat > 0; }

void Pix2PixHDTask::make_discriminator() {
  nets::MultiscaleDiscriminatorOptions d;
  nlohmann::json dj = options_.discriminator_options;
  dj["in_channels"] = total_channels(input_maps()) + total_channels(output_maps());
  nets::from_json(dj, d);
  d.get_interm_feat = true;
  D_ = nets::MultiscaleDiscriminator(d);
}

std::map<std::string, std::shared_ptr<torch::nn::Module>> Pix2PixHDTask::modules() {
  if (!D_) return {{"G", G_}};
  return {{"G", G_}, {"D", D_.ptr()}};
}

std::vector<train::OptimizerSpec> Pix2PixHDTask::optimizers() {
  const auto schedule = train::Schedule::linear_from(options_.lr_decay, options_.steps);
  std::vector<train::OptimizerSpec> specs = {
      adam("G", G_->parameters(), options_.lr, options_.beta1, options_.beta2, schedule)};
  // Without the adversarial and feature-matching terms nothing reads D: it is neither built nor trained.
  if (D_) specs.push_back(adam("D", D_->parameters(), options_.lr, options_.beta1, options_.beta2, schedule));
  return specs;
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
    train::Losses out;
    if (D_) {
      auto pred_fake = D_->forward(torch::cat({in, fake}, 1));
      losses::MultiscaleOutputs pred_real;
      {
        torch::NoGradGuard no_grad;
        pred_real = D_->forward(torch::cat({in, real}, 1));
      }
      out["gan"] = options_.lambda_gan * losses::gan_loss(pred_fake, true, losses::GanKind::Lsgan, false);
      out["feat"] = losses::feature_matching(pred_fake, pred_real, options_.lambda_feat);
    }
    if (options_.lambda_perceptual > 0)
      out["vgg"] = options_.lambda_perceptual * perceptual_all(vgg_, (fake + 1) * 0.5, (real + 1) * 0.5);
    if (options_.lambda_l1 > 0) {  // over the UV layout: the texels outside it are never drawn
      auto layout = uv_layout(in).expand_as(fake);
      out["l1"] = options_.lambda_l1 * ((fake - real).abs() * layout).sum() / layout.sum().clamp_min(1);
    }
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
  auto x = input(batch).to(device);
  auto layout = uv_layout(x);
  auto b = split_maps(mm_only_maps(x, real, layout), output_maps());
  std::map<std::string, double> out;
  for (const auto& m : output_maps()) {
    out["psnr_" + m.name] = losses::psnr(f[m.name], r[m.name], layout).mean().item<double>();
    out["psnr_mm_" + m.name] = losses::psnr(b[m.name], r[m.name], layout).mean().item<double>();
  }
  // The UV net's start: the unwrap where seen over the 3DMM albedo.
  auto start = (uv_base(x).narrow(1, 0, 3) + 1) * 0.5;
  out["psnr_unwrap_diffuse"] = losses::psnr(start, r["diffuse"], layout).mean().item<double>();
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

// ---- loading the trained net ----

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

// ---- the training command ----

train::TrainResult train_texture(const TrainRunOptions& run, TextureNetOptions model) {
  run.check();
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
  auto options = trainer_options(run, model);
  // A run's stored model options read back in today's keys: "decay_start" of runs from before lr_decay, and options
  // added since at their defaults (clip_grad_norm: off), so earlier runs resume.
  options.upgrade_config = [](nlohmann::json& stored) {
    if (stored.contains("model")) stored["model"] = nlohmann::json(stored["model"].get<TextureNetOptions>());
  };
  train::Trainer trainer(options, task, train_data, val.get());
  return trainer.run();
}

}  // namespace bareskin::texture
