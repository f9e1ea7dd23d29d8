#include "training/recon.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "core/error.h"
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
}

void to_json(nlohmann::json& j, const ReconNetOptions& o) {
  j = {{"arch", o.arch}, {"width", o.width}, {"gamma", o.gamma}, {"translation_scale", o.translation_scale}};
}

void from_json(const nlohmann::json& j, ReconNetOptions& o) {
  for (const auto& [k, v] : j.items()) {
    if (k == "arch" && v.is_string()) o.arch = v.get<std::string>();
    else if (k == "width" && v.is_number_integer()) o.width = v.get<int>();
    else if (k == "gamma" && v.is_boolean()) o.gamma = v.get<bool>();
    else if (k == "translation_scale" && v.is_number()) o.translation_scale = v.get<double>();
    else throw InvalidInput("", "net option '" + k + "' is unknown or of the wrong type", "use arch, width, gamma, translation_scale");
  }
  o.check();
}

ReconNetImpl::ReconNetImpl(const ReconNetOptions& options, const CoefficientLayout& model_layout)
    : options_(options), layout_(model_layout) {
  options_.check();
  layout_.gamma = options_.gamma;
  nets::ResNetOptions r;
  r.depth = options_.arch == "resnet50" ? 50 : options_.arch == "resnet34" ? 34 : 18;
  r.width = options_.width;
  r.num_classes = 0;
  backbone_ = register_module("backbone", nets::ResNet(r));
  const int64_t c = backbone_->feature_channels();
  alpha_ = register_module("alpha", zero_linear(c, layout_.id));
  beta_ = register_module("beta", zero_linear(c, layout_.exp));
  delta_ = register_module("delta", zero_linear(c, layout_.app));
  rotation_ = register_module("rotation", zero_linear(c, 3));
  translation_ = register_module("translation", zero_linear(c, 3));
  if (layout_.gamma) gamma_ = register_module("gamma", zero_linear(c, 27));
}

torch::Tensor ReconNetImpl::forward(const torch::Tensor& image) {
  const torch::Tensor f = backbone_->features(image);
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

void to_json(nlohmann::json& j, const LossOptions& o) {
  j = {{"supervision", to_string(o.supervision)}, {"truth", o.truth}, {"w_alpha", o.w_alpha}, {"w_beta", o.w_beta},
       {"w_delta", o.w_delta}, {"w_rotation", o.w_rotation}, {"w_translation", o.w_translation},
       {"w_gamma", o.w_gamma}, {"rotation_unit", o.rotation_unit}, {"translation_unit", o.translation_unit},
       {"gamma_unit", o.gamma_unit}, {"photo", o.photo}, {"landmark", o.landmark}, {"reg", o.reg},
       {"reg_alpha", o.reg_alpha}, {"reg_beta", o.reg_beta}, {"reg_delta", o.reg_delta},
       {"gamma_mono", o.gamma_mono}, {"identity", o.identity}};
}

void from_json(const nlohmann::json& j, LossOptions& o) {
  nlohmann::json all;
  to_json(all, o);
  for (const auto& [k, v] : j.items()) {
    if (!all.contains(k)) throw InvalidInput("", "loss option '" + k + "' is unknown", "see docs/training.md");
    if (k == "supervision") {
      o.supervision = parse_supervision(v.get<std::string>());
      continue;
    }
    if (!v.is_number() || v.get<double>() < 0) throw InvalidInput("", "loss option '" + k + "' must be a number >= 0", "");
    all[k] = v;
  }
  const auto d = [&](const char* k) { return all.at(k).get<double>(); };
  o.truth = d("truth"), o.w_alpha = d("w_alpha"), o.w_beta = d("w_beta"), o.w_delta = d("w_delta");
  o.w_rotation = d("w_rotation"), o.w_translation = d("w_translation"), o.w_gamma = d("w_gamma");
  o.rotation_unit = d("rotation_unit"), o.translation_unit = d("translation_unit"), o.gamma_unit = d("gamma_unit");
  o.photo = d("photo"), o.landmark = d("landmark"), o.reg = d("reg"), o.reg_alpha = d("reg_alpha");
  o.reg_beta = d("reg_beta"), o.reg_delta = d("reg_delta"), o.gamma_mono = d("gamma_mono"), o.identity = d("identity");
}

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

ReconTask::ReconTask(const ReconTaskOptions& options, FaceModel model,
                     std::shared_ptr<detect::FaceRecognitionNet> identity, torch::Device device)
    : options_(options), model_(model.to(device)), identity_(std::move(identity)), device_(device) {
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

#include "core/png.h"
#include "texgen/shards.h"

namespace bareskin::recon {
namespace {

Image to_image(const torch::Tensor& chw) {
  const torch::Tensor t = chw.detach().to(torch::kCPU, torch::kFloat).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image img(int(t.size(1)), int(t.size(0)), int(t.size(2)), ColorSpace::Data);
  std::memcpy(img.pixels.data(), t.data_ptr<float>(), img.pixels.size() * sizeof(float));
  return img;
}

}  // namespace

void write_rendered_faces(const std::string& dir, const FaceModel& model, const RenderedFacesOptions& o) {
  torch::NoGradGuard guard;
  torch::Generator gen = at::detail::createCPUGenerator(o.seed);
  const CoefficientLayout l = model.layout(true);
  const Camera camera = canonical_camera(o.size);
  // Skin: every region but eyes, brows and mouth.
  torch::Tensor skin_vertex = torch::ones({model.vertices(), 1});
  for (size_t k = 0; k < model.region_names().size(); ++k) {
    const std::string& n = model.region_names()[k];
    if (n == "eyes" || n == "brows" || n == "mouth") skin_vertex.masked_fill_((model.vertex_region() == int64_t(k)).unsqueeze(1), 0);
  }
  shards::ShardWriter writer(dir, "faces", o.per_shard);
  for (int64_t i = 0; i < o.count; ++i) {
    torch::Tensor c = torch::zeros({1, l.size()});
    c.narrow(1, 0, l.id + l.exp + l.app).normal_(0, o.sigma, gen);
    const torch::Tensor u = torch::rand({8}, gen) * 2 - 1;
    c[0][l.rotation_offset()] = 0.15 * u[0];
    c[0][l.rotation_offset() + 1] = o.max_yaw * u[1];
    c[0][l.rotation_offset() + 2] = 0.1 * u[2];
    c[0][l.translation_offset()] = 5 * u[3];
    c[0][l.translation_offset() + 1] = 5 * u[4];
    c[0][l.translation_offset() + 2] = 20 * u[5];
    torch::Tensor g = c.narrow(1, l.gamma_offset(), 27).view({3, 9});
    const torch::Tensor mono = torch::randn({9}, gen) * 0.12;
    g.copy_(mono.unsqueeze(0) + torch::randn({3, 9}, gen) * 0.02);
    g.select(1, 0).add_(0.8 + 0.2 * u[6].item<double>());
    const FaceRender r = model.render(c, camera);
    const torch::Tensor bg = (0.25 + 0.2 * u[7]) + 0.05 * torch::randn({1, 3, o.size, o.size}, gen);
    const torch::Tensor before = linear_to_srgb(r.colour.clamp(0, 1)) * r.mask + bg.clamp(0, 1) * (1 - r.mask);
    // The skin mask: the per-vertex indicator through the rasterizer (nearest: > 0.5).
    const torch::Tensor pos = r.projected;
    const render_torch::Raster raster = render_torch::rasterize(pos, model.triangles(), o.size, o.size);
    const torch::Tensor skin = (render_torch::interpolate(skin_vertex.unsqueeze(0), pos, model.triangles(), raster) > 0.5)
                                   .to(torch::kFloat)
                                   .permute({0, 3, 1, 2});
    char key[24];
    std::snprintf(key, sizeof key, "%08lld", static_cast<long long>(i));
    nlohmann::json meta = {{"subject", "render/" + std::string(key)}, {"split", o.split}, {"style", "none"},
                           {"coefficients", coefficients_to_json(c[0], l)}, {"has_truth", true},
                           {"camera", {{"focal", camera.focal}, {"cx", camera.cx}, {"cy", camera.cy},
                                       {"width", o.size}, {"height", o.size}}},
                           {"align", {{"similarity", {{1, 0, 0}, {0, 1, 0}}}, {"source", "truth"}}}};
    const torch::Tensor lm = r.landmarks[0].to(torch::kDouble).contiguous();
    nlohmann::json points = nlohmann::json::array();
    for (int k = 0; k < 68; ++k) points.push_back({lm[k][0].item<double>(), lm[k][1].item<double>()});
    meta["landmarks"] = points;
    meta["landmarks_visible"] = std::vector<bool>(68, true);
    shards::Sample s;
    s.key = key;
    const std::string png = encode_png(to_image(before[0]));
    s.members["before.png"] = png;
    s.members["makeup.png"] = png;
    s.members["skin.png"] = encode_png(to_image(skin[0]));
    s.members["face.png"] = encode_png(to_image(r.mask[0]));
    s.members["json"] = meta.dump();
    writer.write(s);
  }
  shards::Manifest manifest;
  manifest.shards = writer.finish();
  manifest.metadata = {{"generator", "bareskin recon::write_rendered_faces"}, {"model", model.path()},
                       {"size", o.size}, {"seed", o.seed}, {"split", o.split}};
  shards::write_manifest(dir, manifest);
}

}  // namespace bareskin::recon

#include <chrono>
#include <filesystem>

#include "core/safetensors.h"
#include "training/checkpoint.h"

namespace bareskin::recon {

TrainedRecon load_recon(const std::string& run, const FaceModel& model, torch::Device device) {
  namespace fs = std::filesystem;
  const std::string path = fs::is_directory(run) ? train::checkpoint_path(run) : run;
  const std::string hint = "give the run folder of 'bareskin train recon' trained with this model file";
  if (!fs::exists(path)) throw IoError(path, "does not exist", hint);
  nlohmann::json meta;
  std::string module;
  {
    const SafeTensors file = SafeTensors::open(path);
    const auto it = file.metadata().find("bareskin.checkpoint");
    if (it == file.metadata().end()) throw InvalidInput(path, "is not a training checkpoint", hint);
    meta = nlohmann::json::parse(it->second, nullptr, false);
    if (!meta.is_object() || meta.value("task", "") != "recon") {
      throw InvalidInput(path, "is not a checkpoint of 'bareskin train recon' (task '" +
                                   (meta.is_object() ? meta.value("task", "") : std::string()) + "')", hint);
    }
    for (const std::string& n : file.names()) {
      if (n.rfind("module.F.", 0) == 0) module = "F";
      if (n.rfind("module.E.", 0) == 0) module = "E";
    }
    if (module.empty()) throw InvalidInput(path, "holds no net F or E", hint);
  }
  TrainedRecon out;
  out.config = meta.value("config", nlohmann::json::object());
  const nlohmann::json layout = out.config.value("layout", nlohmann::json::object());
  const CoefficientLayout l = model.layout();
  if (layout.value("id", -1) != l.id || layout.value("exp", -1) != l.exp || layout.value("app", -1) != l.app) {
    throw InvalidInput(path, "was trained for a model with K_id " + std::to_string(layout.value("id", -1)) + ", K_exp " +
                                 std::to_string(layout.value("exp", -1)) + ", K_app " + std::to_string(layout.value("app", -1)) +
                                 ", not " + model.path() + " (" + l.describe() + ")",
                       "give --model the model file the run was trained with");
  }
  ReconNetOptions o;
  from_json(out.config.at("net"), o);
  out.net = ReconNet(o, l);
  train::load_module_weights(path, module, *out.net);
  out.net->to(device);
  out.net->eval();
  out.model = model.to(device);
  out.image_size = out.config.value("image_size", int64_t(256));
  out.module = module;
  out.device = device;
  return out;
}

Reconstruction reconstruct(const TrainedRecon& r, const torch::Tensor& aligned, const torch::Tensor& detected,
                           const ConfidenceOptions& co) {
  torch::NoGradGuard guard;
  if (aligned.dim() != 3 || aligned.size(0) != 3 || aligned.size(1) != r.image_size || aligned.size(2) != r.image_size) {
    throw InvalidInput("", "the aligned face must be [3, " + std::to_string(r.image_size) + ", " +
                               std::to_string(r.image_size) + "]", "align the photo to the net's frame (detect/align.h)");
  }
  Reconstruction out;
  const torch::Tensor image = aligned.unsqueeze(0).to(r.device, torch::kFloat);
  const auto t0 = std::chrono::steady_clock::now();
  ReconNet net = r.net;  // a holder: the same module
  torch::Tensor pred = net->forward(image);
  out.milliseconds = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  FaceCoefficients c = r.model.split(pred);
  if (!c.gamma.defined()) c.gamma = ambient_gamma(pred.options()).unsqueeze(0);
  pred = r.model.join(c);
  const FaceRender f = r.model.render(c, canonical_camera(int(r.image_size)));
  out.coefficients = pred[0].cpu();
  out.landmarks = f.landmarks[0].cpu();
  out.overlay = (linear_to_srgb(f.colour.clamp(0, 1)) * f.mask + image * (1 - f.mask))[0].cpu();
  const torch::Tensor se = ((f.colour - srgb_to_linear(image)).pow(2) * f.mask).sum() / (3 * f.mask.sum()).clamp_min(1);
  out.psnr_db = -10 * std::log10(std::max(se.item<double>(), 1e-10));
  double score = 1 / (1 + std::exp(-(out.psnr_db - co.psnr_db) / 2));
  out.flagged = out.psnr_db < co.psnr_db;
  if (detected.defined()) {
    out.landmark_residual_px = (out.landmarks - detected.to(torch::kFloat).cpu()).pow(2).sum(1).mean().sqrt().item<double>();
    score *= std::exp(-0.5 * std::pow(out.landmark_residual_px / co.landmark_px, 2));
    out.flagged = out.flagged || out.landmark_residual_px > co.landmark_px;
  }
  out.confidence = score;
  return out;
}

}  // namespace bareskin::recon
