#include "recon/recon.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <type_traits>

#include "core/error.h"
#include "core/json_options.h"
#include "render/sh.h"
#include "training/identity.h"

namespace bareskin::recon {
namespace {

constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

torch::nn::Linear zero_linear(int64_t in, int64_t out) {
  torch::nn::Linear l(in, out);
  torch::NoGradGuard guard;
  l->weight.zero_();
  l->bias.zero_();
  return l;
}

// Deep3DFaceRecon's landmark weights: 20 on the nose ridge's lower points (28–30) and the inner lips (60–67).
torch::Tensor landmark_weights(torch::TensorOptions options) {
  torch::Tensor w = torch::ones({68}, options);
  w.narrow(0, 28, 3).fill_(20);
  w.narrow(0, 60, 8).fill_(20);
  return w;
}

}  // namespace

torch::Tensor srgb_to_linear(const torch::Tensor& x) {
  return torch::where(x <= 0.04045, x / 12.92, torch::pow((x.clamp_min(0.04045) + 0.055) / 1.055, 2.4));
}

torch::Tensor linear_to_srgb(const torch::Tensor& x) {
  return torch::where(x <= 0.0031308, x * 12.92, 1.055 * torch::pow(x.clamp_min(0.0031308), 1 / 2.4) - 0.055);
}

void ReconNetOptions::check() const {
  if (arch != "resnet18" && arch != "resnet34" && arch != "resnet50") {
    throw InvalidInput("", "unknown arch '" + arch + "'", "use resnet50 (the teacher F) or resnet18 (the student E)");
  }
  if (width < 1 || width > 1024) throw InvalidInput("", "width must be 1 to 1024", "");
  if (!(translation_scale > 0)) throw InvalidInput("", "translation_scale must be > 0", "");
  if (pool_grid < 1 || pool_grid > 16) throw InvalidInput("", "pool_grid must be 1 to 16", "");
}

namespace {
// The keys of ReconNetOptions, listed once (core/json_options.h).
const auto kNetFields = [](auto& v, auto& o) {
  v("arch", o.arch);
  v("width", o.width);
  v("gamma", o.gamma);
  v("translation_scale", o.translation_scale);
  v("pool_grid", o.pool_grid);
};
}  // namespace

void to_json(nlohmann::json& j, const ReconNetOptions& o) { json_options::write(j, o, kNetFields); }
void from_json(const nlohmann::json& j, ReconNetOptions& o) { json_options::read(j, o, "recon net", kNetFields); }

ReconNetImpl::ReconNetImpl(const ReconNetOptions& options, const CoefficientLayout& model_layout)
    : options_(options), layout_(model_layout) {
  options_.check();
  layout_.gamma = options_.gamma;
  nets::ResNetOptions r;
  r.depth = options_.arch == "resnet50" ? 50 : options_.arch == "resnet34" ? 34 : 18;
  r.width = options_.width;
  r.num_classes = 0;
  backbone_ = register_module("backbone", nets::ResNet(r));
  const int64_t c = backbone_->feature_channels() * options_.pool_grid * options_.pool_grid;
  alpha_ = register_module("alpha", zero_linear(c, layout_.id));
  beta_ = register_module("beta", zero_linear(c, layout_.exp));
  delta_ = register_module("delta", zero_linear(c, layout_.app));
  rotation_ = register_module("rotation", zero_linear(c, 3));
  translation_ = register_module("translation", zero_linear(c, 3));
  if (layout_.gamma) gamma_ = register_module("gamma", zero_linear(c, 27));
}

torch::Tensor ReconNetImpl::forward(const torch::Tensor& image) {
  const int64_t g = options_.pool_grid;  // 1: the backbone's own global average, the same kernel
  const torch::Tensor f = torch::adaptive_avg_pool2d(backbone_->trunk(image), {g, g}).flatten(1);
  std::vector<torch::Tensor> out = {alpha_(f), beta_(f), delta_(f), rotation_(f),
                                    translation_(f) * options_.translation_scale};
  if (gamma_) out.push_back(gamma_(f) + ambient_gamma(f.options()));
  return torch::cat(out, 1);
}

Supervision parse_supervision(const std::string& name) {
  if (name == "truth") return Supervision::Truth;
  if (name == "self") return Supervision::Self;
  if (name == "both") return Supervision::Both;
  throw InvalidInput("", "unknown supervision '" + name + "'", "use truth, self or both");
}

std::string to_string(Supervision s) {
  return s == Supervision::Truth ? "truth" : s == Supervision::Self ? "self" : "both";
}

void to_json(nlohmann::json& j, Supervision s) { j = to_string(s); }
void from_json(const nlohmann::json& j, Supervision& s) { s = parse_supervision(j.get<std::string>()); }

namespace {
// The keys of LossOptions, listed once (core/json_options.h).
const auto kLossFields = [](auto& v, auto& o) {
  v("supervision", o.supervision);
  v("truth", o.truth);
  v("w_alpha", o.w_alpha);
  v("w_beta", o.w_beta);
  v("w_delta", o.w_delta);
  v("w_rotation", o.w_rotation);
  v("w_translation", o.w_translation);
  v("w_gamma", o.w_gamma);
  v("rotation_unit", o.rotation_unit);
  v("translation_unit", o.translation_unit);
  v("gamma_unit", o.gamma_unit);
  v("shape", o.shape);
  v("photo", o.photo);
  v("landmark", o.landmark);
  v("reg", o.reg);
  v("reg_alpha", o.reg_alpha);
  v("reg_beta", o.reg_beta);
  v("reg_delta", o.reg_delta);
  v("gamma_mono", o.gamma_mono);
  v("identity", o.identity);
};

// Every number of LossOptions is a weight or a unit: ≥ 0.
struct NonNegative {
  template <typename T>
  void operator()(const char* key, const T& value) const {
    if constexpr (std::is_floating_point_v<T>) {
      if (!(value >= 0)) throw InvalidInput("", std::string("loss option '") + key + "' must be a number >= 0", "");
    }
  }
};
}  // namespace

void LossOptions::check() const {
  NonNegative v;
  kLossFields(v, *this);
}

void to_json(nlohmann::json& j, const LossOptions& o) { json_options::write(j, o, kLossFields); }
void from_json(const nlohmann::json& j, LossOptions& o) { json_options::read(j, o, "recon loss", kLossFields); }

ReconTargets targets_from_batch(const data::Batch& batch, const FaceModel& model, const std::string& input) {
  ReconTargets t;
  t.image = batch.at(input);
  if (t.image.size(1) != 3) throw InvalidInput("batch", "member '" + input + "' is not RGB", "");
  const int64_t B = batch.size();
  const auto it = batch.tensors.find("skin");
  t.skin = it != batch.tensors.end() ? (it->second.narrow(1, 0, 1) > 0.5).to(t.image.dtype())
                                     : torch::ones({B, 1, t.image.size(2), t.image.size(3)}, t.image.options());
  const auto lm = batch.tensors.find("landmarks");
  const CoefficientLayout layout = model.layout(true);
  t.truth = torch::zeros({B, layout.size()});
  t.has_truth = torch::zeros({B});
  t.landmark_weight = torch::ones({B, 68});
  for (int64_t b = 0; b < B; ++b) {
    const nlohmann::json& m = batch.meta.at(size_t(b));
    const std::string source = "faces sample " + batch.keys.at(size_t(b));
    if (m.value("has_truth", true) && m.contains("coefficients")) {
      t.truth[b] = coefficients_from_json(m.at("coefficients"), layout, source);
      t.has_truth[b] = 1;
    }
    if (m.contains("landmarks_visible") && m.at("landmarks_visible").is_array() && m.at("landmarks_visible").size() == 68) {
      for (int k = 0; k < 68; ++k) t.landmark_weight[b][k] = m.at("landmarks_visible")[size_t(k)].get<bool>() ? 1.0 : 0.0;
    }
  }
  if (lm != batch.tensors.end()) {
    if (lm->second.dim() != 3 || lm->second.size(1) != 68) throw InvalidInput("batch", "landmarks are not 68 points", "");
    t.landmarks = lm->second;
  }
  return t;
}

void jitter_colour(data::Example& example, const std::string& member, double strength, uint64_t seed) {
  if (strength == 0) return;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  double gain[3];
  for (double& g : gain) g = std::exp(strength * u(rng));
  torch::Tensor& image = example.tensors.at(member);
  if (image.dim() != 3 || image.size(0) != 3)
    throw InvalidInput("faces sample " + example.key, "member '" + member + "' is not RGB", "");
  const torch::Tensor g = torch::tensor({gain[0], gain[1], gain[2]}, image.options()).view({3, 1, 1});
  image = linear_to_srgb((srgb_to_linear(image) * g).clamp(0, 1));
  if (!example.meta.contains("coefficients") || !example.meta["coefficients"].contains("gamma")) return;
  nlohmann::json& gamma = example.meta["coefficients"]["gamma"];
  if (!gamma.is_array() || gamma.size() != 27) return;  // targets_from_batch names the sample
  for (const auto& v : gamma)
    if (!v.is_number()) return;
  for (size_t i = 0; i < 27; ++i) gamma[i] = gamma[i].get<double>() * gain[i / 9];  // channel-major
}

ReconTargets resized(const ReconTargets& t, int64_t size) {
  const int64_t from = t.image.size(3);
  if (from == size && t.image.size(2) == size) return t;
  namespace F = torch::nn::functional;
  ReconTargets out = t;
  const auto area = [&](const torch::Tensor& x) {
    auto opt = F::InterpolateFuncOptions().size(std::vector<int64_t>{size, size});
    return size < from ? F::interpolate(x, opt.mode(torch::kArea))
                       : F::interpolate(x, opt.mode(torch::kBilinear).align_corners(false));
  };
  out.image = area(t.image);
  out.skin = (area(t.skin) > 0.5).to(t.skin.dtype());
  if (t.landmarks.defined()) out.landmarks = t.landmarks * (double(size) / double(from));
  return out;
}

torch::Tensor photo_loss(const torch::Tensor& rendered, const torch::Tensor& target, const torch::Tensor& mask) {
  const torch::Tensor d = torch::sqrt(1e-6 + (rendered - target).pow(2).sum(1, true)) * mask;
  return d.sum() / mask.sum().clamp_min(1.0);
}

torch::Tensor landmark_loss(const torch::Tensor& predicted, const torch::Tensor& target, const torch::Tensor& visible,
                            int64_t image_size) {
  const double s = 224.0 / double(image_size);  // Deep3DFaceRecon's weight is for 224² pixels
  const torch::Tensor d2 = ((predicted - target) * s).pow(2).sum(2);  // [B, 68]
  return (d2 * landmark_weights(d2.options()) * visible.to(d2.options())).sum() / double(predicted.size(0) * 68);
}

torch::Tensor gamma_loss(const torch::Tensor& gamma) {
  const torch::Tensor g = gamma.reshape({-1, 3, 9});
  return (g - g.mean(1, true)).pow(2).mean();
}

torch::Tensor coefficient_loss(const torch::Tensor& predicted, const torch::Tensor& truth, const torch::Tensor& has_truth,
                               const CoefficientLayout& l, const LossOptions& o) {
  const torch::Tensor rows = has_truth.to(predicted.options()).unsqueeze(1);
  const double n = std::max(1.0, has_truth.sum().item<double>());
  torch::Tensor total = torch::zeros({}, predicted.options());
  const auto group = [&](int64_t at, int64_t len, double w, double unit) {
    if (len == 0 || w == 0) return;
    const torch::Tensor d = (predicted.narrow(1, at, len) - truth.narrow(1, at, len).to(predicted.options())) / unit;
    total = total + w * (d.pow(2) * rows).sum() / (n * double(len));
  };
  group(0, l.id, o.w_alpha, 1);
  group(l.id, l.exp, o.w_beta, 1);
  group(l.id + l.exp, l.app, o.w_delta, 1);
  group(l.rotation_offset(), 3, o.w_rotation, o.rotation_unit);
  group(l.translation_offset(), 3, o.w_translation, o.translation_unit);
  if (predicted.size(1) == l.gamma_offset() + 27) group(l.gamma_offset(), 27, o.w_gamma, o.gamma_unit);
  return total;
}

torch::Tensor shape_loss(const FaceModel& model, const torch::Tensor& predicted, const torch::Tensor& truth,
                         const torch::Tensor& has_truth) {
  const FaceCoefficients p = model.split(predicted), q = model.split(truth.to(predicted.options()));
  // The model is linear: one product with the bases instead of two shapes. ε keeps the distance's gradient finite
  // where a vertex is exact.
  const torch::Tensor d = (model.displacement(p.alpha - q.alpha, p.beta - q.beta).pow(2).sum(2) + 1e-8).sqrt();
  const torch::Tensor rows = has_truth.to(predicted.options());
  return (d.mean(1) * rows).sum() / std::max(1.0, has_truth.sum().item<double>());
}

namespace {

// The light of a prediction: its own γ, else the truth's (and the samples without truth are masked out).
torch::Tensor light_of(const FaceModel& model, const FaceCoefficients& c, const ReconTargets& t, torch::Tensor& rows) {
  rows = torch::ones({c.alpha.size(0)}, c.alpha.options());
  if (c.gamma.defined()) return c.gamma;
  rows = t.has_truth.to(c.alpha.options());
  return t.truth.to(c.alpha.options()).narrow(1, model.layout(true).gamma_offset(), 27);
}

}  // namespace

train::Losses recon_losses(const FaceModel& model, const torch::Tensor& predicted, const ReconTargets& t,
                           const LossOptions& o, detect::FaceRecognitionNet* identity_net, int64_t image_size) {
  train::Losses L;
  const bool truth = o.supervision != Supervision::Self, self = o.supervision != Supervision::Truth;
  const CoefficientLayout layout = model.layout(true);
  if (truth && o.truth > 0) L["truth"] = o.truth * coefficient_loss(predicted, t.truth.to(predicted.device()), t.has_truth, layout, o);
  if (truth && o.shape > 0) L["shape"] = o.shape * shape_loss(model, predicted, t.truth, t.has_truth);
  if (!self) return L;
  FaceCoefficients c = model.split(predicted);
  const int64_t B = predicted.size(0);
  torch::Tensor rows;
  c.gamma = light_of(model, c, t, rows);
  const Camera camera = canonical_camera(int(image_size));
  if (o.photo > 0 || o.identity > 0) {
    const FaceRender r = model.render(c, camera);
    const torch::Tensor target = t.image.to(predicted.options());
    const torch::Tensor mask = r.mask * t.skin.to(predicted.options()) * rows.reshape({B, 1, 1, 1});
    if (o.photo > 0) L["photo"] = o.photo * photo_loss(r.colour, srgb_to_linear(target), mask);
    if (o.identity > 0) {
      if (!identity_net) throw InvalidInput("", "the identity term needs face-api's recognition net", "run 'make deps' or set identity to 0");
      const torch::Tensor over = linear_to_srgb(r.colour.clamp(0, 1)) * r.mask + target * (1 - r.mask);
      L["identity"] = o.identity * losses::identity_loss(*identity_net, over, target.detach());
    }
  }
  if (o.landmark > 0 && t.landmarks.defined()) {
    L["landmark"] = o.landmark * landmark_loss(model.landmarks(c, camera), t.landmarks.to(predicted.options()),
                                               t.landmark_weight.to(predicted.options()), image_size);
  }
  if (o.reg > 0) {
    L["reg"] = o.reg * (o.reg_alpha * c.alpha.pow(2).sum() + o.reg_beta * c.beta.pow(2).sum() +
                        o.reg_delta * c.delta.pow(2).sum()) / double(B);
  }
  if (o.gamma_mono > 0 && predicted.size(1) == layout.size()) L["gamma"] = o.gamma_mono * gamma_loss(c.gamma);
  return L;
}

std::map<std::string, std::vector<double>> recon_metrics(const FaceModel& model, const torch::Tensor& predicted,
                                                         const ReconTargets& t, int64_t image_size) {
  torch::NoGradGuard guard;
  const int64_t B = predicted.size(0);
  const auto opt = predicted.options();
  const CoefficientLayout l = model.layout(true);
  FaceCoefficients p = model.split(predicted);
  const FaceCoefficients q = model.split(t.truth.to(opt));
  torch::Tensor rows;
  p.gamma = light_of(model, p, t, rows);
  const Camera camera = canonical_camera(int(image_size));
  const FaceRender r = model.render(p, camera);
  std::map<std::string, std::vector<double>> m;
  const torch::Tensor truth_vertices = model.posed(q);
  const torch::Tensor shape_err = (model.shape(p.alpha, p.beta) - model.shape(q.alpha, q.beta)).norm(2, 2).mean(1);
  const torch::Tensor posed_err = (r.vertices - truth_vertices).norm(2, 2).mean(1);
  const torch::Tensor target_lm = t.landmarks.defined() ? t.landmarks.to(opt) : model.landmarks(q, camera);
  const torch::Tensor lm = (r.landmarks - target_lm).pow(2).sum(2).mean(1).sqrt();
  const torch::Tensor mask = r.mask * t.skin.to(opt);
  const torch::Tensor se = ((r.colour - srgb_to_linear(t.image.to(opt))).pow(2) * mask).sum({1, 2, 3}) /
                           (3 * mask.sum({1, 2, 3})).clamp_min(1);
  const torch::Tensor psnr = -10 * torch::log10(se.clamp_min(1e-10));
  const auto rms = [&](const torch::Tensor& a, const torch::Tensor& b) {
    return a.numel() ? (a - b).pow(2).mean(1).sqrt() : torch::zeros({B}, opt);
  };
  const torch::Tensor ga = predicted.size(1) == l.size() ? rms(p.gamma, q.gamma) : torch::full({B}, kNan, opt);
  const torch::Tensor ea = rms(p.alpha, q.alpha), eb = rms(p.beta, q.beta), ed = rms(p.delta, q.delta);
  const torch::Tensor er = rms(p.rotation, q.rotation) * (180 / M_PI);
  for (int64_t b = 0; b < B; ++b) {
    const bool has = t.has_truth[b].item<double>() > 0;
    const auto v = [&](const torch::Tensor& x) { return has ? x[b].item<double>() : kNan; };
    m["shape_mm"].push_back(v(shape_err));
    m["posed_mm"].push_back(v(posed_err));
    m["landmark_px"].push_back(t.landmarks.defined() || has ? lm[b].item<double>() : kNan);
    m["skin_psnr"].push_back(rows[b].item<double>() > 0 ? psnr[b].item<double>() : kNan);
    m["gamma_rmse"].push_back(v(ga));
    m["alpha_sigma"].push_back(v(ea));
    m["beta_sigma"].push_back(v(eb));
    m["delta_sigma"].push_back(v(ed));
    m["rotation_deg"].push_back(v(er));
  }
  return m;
}

torch::Tensor overlay(const FaceModel& model, const torch::Tensor& predicted, const torch::Tensor& image,
                      const torch::Tensor& light) {
  torch::NoGradGuard guard;
  FaceCoefficients c = model.split(predicted);
  if (!c.gamma.defined()) c.gamma = light.defined() ? light : ambient_gamma(predicted.options()).expand({predicted.size(0), 27});
  const FaceRender r = model.render(c, canonical_camera(int(image.size(3))));
  return linear_to_srgb(r.colour.clamp(0, 1)) * r.mask + image.to(predicted.options()) * (1 - r.mask);
}

void ReconTaskOptions::check() const {
  net.check();
  loss.check();
  schedule.check();
  if (input != "before" && input != "makeup")
    throw InvalidInput("--input", "'" + input + "' is not a member the net can see", "use before or makeup");
  if (!(lr > 0 && lr < 1)) throw InvalidInput("--lr", "must lie in (0, 1)", "e.g. --lr 1e-4");
  if (image_size < 16 || image_size > 4096)
    throw InvalidInput("--image-size", std::to_string(image_size) + " is outside [16, 4096]", "e.g. --image-size 128");
}

ReconTask::ReconTask(const ReconTaskOptions& options, FaceModel model,
                     std::shared_ptr<detect::FaceRecognitionNet> identity, torch::Device device)
    : options_(options), model_(model.to(device)), identity_(std::move(identity)), device_(device) {
  options_.check();
  net_ = ReconNet(options_.net, model_.layout());
  net_->to(device_);
  if (options_.loss.identity > 0 && options_.loss.supervision != Supervision::Truth && !identity_) {
    throw InvalidInput("", "the identity term needs face-api's recognition net", "run 'make deps' or set identity to 0");
  }
}

std::string ReconTask::module_name() const { return options_.net.gamma ? "F" : "E"; }

std::map<std::string, std::shared_ptr<torch::nn::Module>> ReconTask::modules() {
  return {{module_name(), net_.ptr()}};
}

std::vector<train::OptimizerSpec> ReconTask::optimizers() {
  train::OptimizerSpec s;
  s.name = module_name();
  s.groups = {{"net", net_->parameters(), options_.lr}};
  s.schedule = options_.schedule;
  return {s};
}

train::Losses ReconTask::loss(size_t, const data::Batch& batch) {
  const ReconTargets t = resized(targets_from_batch(batch, model_, options_.input), options_.image_size);
  const torch::Tensor pred = net_->forward(t.image.to(device_));
  return recon_losses(model_, pred, t, options_.loss, identity_ ? identity_.get() : nullptr, options_.image_size);
}

std::map<std::string, double> ReconTask::evaluate(const data::Batch& batch) {
  const ReconTargets t = resized(targets_from_batch(batch, model_, options_.input), options_.image_size);
  const torch::Tensor pred = net_->forward(t.image.to(device_));
  std::map<std::string, double> out;
  for (const auto& [name, values] : recon_metrics(model_, pred, t, options_.image_size)) {
    double sum = 0;
    int n = 0;
    for (double v : values) {
      if (std::isfinite(v)) sum += v, ++n;
    }
    if (n) out[name] = sum / n;
  }
  return out;
}

std::vector<std::vector<torch::Tensor>> ReconTask::samples(const data::Batch& batch) {
  torch::NoGradGuard guard;
  const ReconTargets t = resized(targets_from_batch(batch, model_, options_.input), options_.image_size);
  const torch::Tensor image = t.image.to(device_);
  const torch::Tensor pred = net_->forward(image);
  torch::Tensor light;
  if (!options_.net.gamma) light = t.truth.to(device_).narrow(1, model_.layout(true).gamma_offset(), 27);
  const torch::Tensor over = overlay(model_, pred, image, light);
  std::vector<std::vector<torch::Tensor>> rows;
  for (int64_t b = 0; b < std::min<int64_t>(batch.size(), 4); ++b) rows.push_back({image[b].cpu(), over[b].cpu()});
  return rows;
}

}  // namespace bareskin::recon
