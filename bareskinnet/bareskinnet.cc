#include "bareskinnet/bareskinnet.h"

#include <ATen/CPUGeneratorImpl.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <random>

#include "core/error.h"
#include "core/json_options.h"
#include "training/checkpoint.h"
#include "training/ranks.h"
#include "core/safetensors.h"
#include "training/lpips.h"
#include "recon/recon.h"
#include "training/tensor_io.h"
#include "render/torch/ops.h"
#include "training/nets/patchgan.h"
#include "training/nets/unet.h"
#include "training/nets/zoo.h"
#include "training/ssim.h"

namespace bareskin::bsn {
namespace F = torch::nn::functional;

void Options::check() const {
  const Options& o = *this;
  if (o.stage != 1 && o.stage != 2) throw InvalidInput("stage " + std::to_string(o.stage), "is not a stage", "use 1 or 2");
  if (o.target != "before" && o.target != "bare")
    throw InvalidInput("target '" + o.target + "'", "is not a target", "use before (the paper) or bare");
  if (o.head != "image" && o.head != "residual" && o.head != "affine")
    throw InvalidInput("head '" + o.head + "'", "is not a generator head", "use residual, affine or image (the paper)");
  if (o.recon != "E" && o.recon != "F")
    throw InvalidInput("recon '" + o.recon + "'", "is not a reconstruction network", "use E (the paper) or F");
  if (o.size < 32 || (o.size & (o.size - 1)) != 0)
    throw InvalidInput("size " + std::to_string(o.size), "is not a power of two ≥ 32", "use 64, 128 or 256");
  if (!(o.ema >= 0 && o.ema < 1))
    throw InvalidInput("ema " + std::to_string(o.ema), "is not a decay in [0, 1)", "use e.g. 0.99, or 0 for no average");
  if (!(o.lr_decay >= 0 && o.lr_decay <= 1))
    throw InvalidInput("lr_decay " + std::to_string(o.lr_decay), "is not a fraction of the steps in [0, 1]",
                       "use e.g. 0.5 (decay over the second half of each stage), or 1 for a constant rate");
  if (!(o.clip_grad_norm >= 0 && std::isfinite(o.clip_grad_norm)))
    throw InvalidInput("clip_grad_norm " + std::to_string(o.clip_grad_norm), "is negative or not finite",
                       "use e.g. 10, or 0 for no clipping");
  for (auto [key, w] : {std::pair<const char*, double>{"w1", o.w1}, {"w2", o.w2}, {"w3", o.w3}, {"w_coeff", o.w_coeff},
                        {"w_land", o.w_land}, {"w_diff", o.w_diff}, {"w_light", o.w_light}, {"w_reg", o.w_reg},
                        {"w_level", o.w_level}, {"w_makeup", o.w_makeup}})
    if (!(w >= 0 && std::isfinite(w)))
      throw InvalidInput(std::string("loss weight ") + key, "is negative or not finite", "give a weight ≥ 0");
  if (!(o.makeup_hue >= 0 && o.makeup_hue <= 1))
    throw InvalidInput("makeup_hue " + std::to_string(o.makeup_hue), "is not a probability in [0, 1]",
                       "use e.g. 0.5, or 0 for the world's own makeup colours");
  if (!(o.makeup_paint >= 0 && o.makeup_paint <= 1))
    throw InvalidInput("makeup_paint " + std::to_string(o.makeup_paint), "is not a probability in [0, 1]",
                       "use e.g. 0.5, or 0 for the world's own makeup");
  losses::parse_gan_kind(o.gan, "gan");
}

namespace {
// The keys of Options, listed once (core/json_options.h).
const auto kOptionsFields = [](auto& v, auto& o) {
  v("stage", o.stage);
  v("target", o.target);
  v("head", o.head);
  v("size", o.size);
  v("g", o.g);
  v("d", o.d);
  v("gan", o.gan);
  v("lpips_trunk", o.lpips_trunk);
  v("w1", o.w1);
  v("w2", o.w2);
  v("w3", o.w3);
  v("w_coeff", o.w_coeff);
  v("w_land", o.w_land);
  v("w_diff", o.w_diff);
  v("w_light", o.w_light);
  v("w_reg", o.w_reg);
  v("recon", o.recon);
  v("tune_f", o.tune_f);
  v("lr_g", o.lr_g);
  v("lr_d", o.lr_d);
  v("lr_e", o.lr_e);
  v("lr_f", o.lr_f);
  v("beta1", o.beta1);
  v("beta2", o.beta2);
  v("ema", o.ema);
  // Written only when set, so that the configurations of runs made before the options existed still match on resume.
  v.unless_default("lr_decay", o.lr_decay);
  v.unless_default("clip_grad_norm", o.clip_grad_norm);
  v.unless_default("w_level", o.w_level);
  v.unless_default("w_makeup", o.w_makeup);
  v.unless_default("makeup_hue", o.makeup_hue);
  v.unless_default("makeup_paint", o.makeup_paint);
  v.unless_default("diff_gain", o.diff_gain);
  // A folder of this machine (set from lpips_trunk by the command), not part of a run's configuration.
  v.unwritten("face_api", o.face_api);
};
}  // namespace

void to_json(nlohmann::json& j, const Options& o) { json_options::write(j, o, kOptionsFields); }
void from_json(const nlohmann::json& j, Options& o) { json_options::read(j, o, "bareskinnet", kOptionsFields); }

Options options_of_run(const nlohmann::json& task) {
  nlohmann::json j = task;
  // Runs written before `head` existed: `residual` true was the residual head; false or no key, the paper's G.
  if (j.is_object() && !j.contains("head")) {
    j["head"] = j.value("residual", false) ? "residual" : "image";
    j.erase("residual");
  }
  Options o;
  from_json(j, o);
  return o;
}

void ablation_preset(const std::string& row, Options& o) {
  if (row == "b") {
    o.w3 = 0;
  } else if (row == "c") {
  } else if (row == "d" || row == "e") {
    o.recon = "F";
    o.tune_f = row == "e";
  } else if (row == "f") {
    o.recon = "E";
    o.w_light = 0;
  } else if (row == "g") {
    o.recon = "E";
  } else {
    throw InvalidInput("ablation row '" + row + "'", "is not a row of the paper's Fig. 7", "use b, c, d, e, f or g");
  }
}

bool ablation_has_stage2(const std::string& row) { return row != "b" && row != "c"; }

double ema_decay(double decay, int64_t n) { return std::min(decay, double(1 + n) / double(10 + n)); }

void ema_update(torch::nn::Module& average, torch::nn::Module& model, double d) {
  torch::NoGradGuard no_grad;
  auto blend = [d](torch::Tensor& a, const torch::Tensor& m) {
    if (a.is_floating_point())
      a.mul_(d).add_(m.detach(), 1 - d);
    else
      a.copy_(m);
  };
  auto ap = average.named_parameters(), mp = model.named_parameters();
  auto ab = average.named_buffers(), mb = model.named_buffers();
  BS_CHECK(ap.size() == mp.size() && ab.size() == mb.size(), "ema_update: the modules differ in layout");
  for (auto& item : ap) blend(item.value(), mp[item.key()]);
  for (auto& item : ab) blend(item.value(), mb[item.key()]);
}

torch::Tensor srgb_to_linear(const torch::Tensor& x) {
  auto c = x.clamp(0, 1);
  return torch::where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055).clamp_min(1e-6).pow(2.4));
}

torch::Tensor diff_loss(const torch::Tensor& unlit, const torch::Tensor& g_out_linear, const torch::Tensor& mask,
                        bool gain) {
  if (!gain) return losses::masked_l1(unlit, g_out_linear, mask);
  auto m = mask.expand_as(unlit);
  auto k = (unlit * g_out_linear * m).sum({2, 3}, true) / (unlit.pow(2) * m).sum({2, 3}, true).clamp_min(1e-8);
  k = k.detach();
  return losses::masked_l1(unlit * k, g_out_linear, mask);
}

torch::Tensor light_loss(const torch::Tensor& lit, const torch::Tensor& before_linear, const torch::Tensor& mask) {
  return losses::masked_l1(lit, before_linear, mask);
}

torch::Tensor landmark_loss(const torch::Tensor& projected, const torch::Tensor& target, double scale) {
  return ((projected - target) * scale).pow(2).sum(-1).mean();
}

torch::Tensor coeff_loss(const torch::Tensor& student, const torch::Tensor& teacher) {
  return (student - teacher).pow(2).mean();
}

torch::Tensor reg_loss(const torch::Tensor& coeff, const CoeffLayout& layout) {
  const int64_t n = layout.rotation_offset();
  return coeff.narrow(1, 0, n).pow(2).sum(1).mean();
}

torch::Tensor level_loss(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask) {
  auto m = mask.expand_as(a);
  return (((a - b) * m).sum({2, 3}) / m.sum({2, 3}).clamp_min(1)).abs().mean();
}

void rotate_makeup_hue(data::Example& example, uint64_t seed, double probability) {
  auto makeup = example.tensors.find("makeup"), before = example.tensors.find("before");
  if (makeup == example.tensors.end() || before == example.tensors.end()) return;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (unit(rng) >= probability) return;
  const double theta = 2 * M_PI * unit(rng), c = std::cos(theta), s = std::sin(theta), k = 1 / std::sqrt(3.0);
  // Rodrigues: R = c·I + s·[k]× + (1 − c)·k kᵀ, k = (1, 1, 1)/√3.
  const double a = c + (1 - c) / 3, b = (1 - c) / 3 - s * k, d = (1 - c) / 3 + s * k;
  const auto R = torch::tensor({a, b, d, d, a, b, b, d, a}, torch::kDouble).view({3, 3}).to(makeup->second.dtype());
  const auto& x = before->second;
  const auto change = (makeup->second - x).reshape({3, -1});
  makeup->second = (x + torch::mm(R, change).view_as(x)).clamp(0, 1);
}

void paint_makeup(data::Example& example, uint64_t seed, double probability) {
  auto makeup = example.tensors.find("makeup"), before = example.tensors.find("before"),
       bare = example.tensors.find("bare"), face = example.tensors.find("face");
  const auto end = example.tensors.end();
  if (makeup == end || before == end || bare == end) return;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (unit(rng) >= probability) return;
  const double opacity = 0.5 + 0.5 * unit(rng);
  const auto colour = [&] {  // HSV → RGB
    const double h = 6 * unit(rng), s = 0.3 + 0.7 * unit(rng), v = 0.1 + 0.9 * unit(rng);
    const double f = h - std::floor(h), p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
    const double rgb[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
    const double* c = rgb[std::min(5, int(h))];
    return torch::tensor({c[0], c[1], c[2]}, torch::kDouble).view({3, 1, 1});
  };
  torch::Tensor& m = makeup->second;
  const auto& x = before->second;
  const int64_t rows = m.size(1), split = int64_t(std::lround(0.55 * double(rows)));
  const auto above = colour(), below = colour();
  const auto layer = torch::cat({above.expand({3, split, m.size(2)}), below.expand({3, rows - split, m.size(2)})}, 1)
                         .to(m.dtype());
  auto alpha = opacity * (((m - x).abs().mean(0, true) - 0.04) / 0.06).clamp(0, 1);
  if (face != end) alpha = alpha * (face->second.narrow(0, 0, 1) >= 0.5).to(m.dtype());
  const auto light = (srgb_to_linear(x) / srgb_to_linear(bare->second).clamp_min(0.02)).clamp(0, 4);
  const auto painted = (1 - alpha) * srgb_to_linear(m) + alpha * srgb_to_linear(layer) * light;
  m = recon::linear_to_srgb(painted.clamp(0, 1));
}

torch::Tensor makeup_region(const torch::Tensor& makeup, const torch::Tensor& before, const torch::Tensor& face) {
  return ((makeup - before).abs().mean(1, true) > 0.02).to(makeup.dtype()) * (face >= 0.5).to(makeup.dtype());
}

torch::Tensor whole_footprint(const torch::Tensor& resized_mask) {
  return (resized_mask >= 0.999).to(resized_mask.dtype());
}

torch::Tensor truth_domain(const std::string& truth, const torch::Tensor& resized_face) {
  if (truth != "bare" || !resized_face.defined()) return {};
  return whole_footprint(resized_face);
}

torch::Tensor masked_psnr(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask) {
  auto m = mask.expand_as(a);
  auto mse = ((a - b).pow(2) * m).sum({1, 2, 3}) / m.sum({1, 2, 3}).clamp_min(1);
  return 10 * torch::log10(1.0 / mse.clamp_min(1e-12));
}

torch::Tensor masked_ssim(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask,
                          const torch::Tensor& domain) {
  losses::SsimOptions o;
  auto map = (domain.defined() ? losses::ssim_map(a, b, domain, o) : losses::ssim_map(a, b, o))
                 .mean(1, true);  // [B, 1, H − w + 1, W − w + 1]
  const int64_t r = o.window / 2;
  auto m = mask.narrow(2, r, map.size(2)).narrow(3, r, map.size(3));
  return (map * m).sum({1, 2, 3}) / m.sum({1, 2, 3}).clamp_min(1);
}

torch::Tensor apply_head(const torch::Tensor& images, const torch::Tensor& y, const std::string& head) {
  if (head == "residual") return images + y;
  if (head == "affine") return images * y.narrow(1, 0, 3).exp() + y.narrow(1, 3, 3);
  return (y + 1) * 0.5;
}

torch::Tensor generator_forward(nets::UNetImpl& G, const torch::Tensor& images, const std::string& head) {
  return apply_head(images, G.forward(images * 2 - 1), head);
}

nlohmann::json generator_options(const nlohmann::json& g, int64_t size, const std::string& head) {
  nlohmann::json o = nets::find_model("unet256").defaults;
  o["num_downs"] = std::max(5, int(std::lround(std::log2(double(size)))));
  o["out_channels"] = head == "affine" ? 6 : 3;
  o.update(g);
  if (o["out_channels"] != (head == "affine" ? 6 : 3))
    throw InvalidInput("G's out_channels " + o["out_channels"].dump(), "does not fit the head '" + head + "'",
                       "leave out_channels out of --g-options (the head sets it)");
  return o;
}

struct BareSkinTask::Nets {
  std::shared_ptr<GeneratorEmaImpl> G_ema;  // Options::ema > 0
  std::shared_ptr<nets::UNetImpl> G;
  std::shared_ptr<nets::PatchGANImpl> D;
  losses::Lpips lpips{nullptr};
  losses::GanKind gan = losses::GanKind::Vanilla;
};

BareSkinTask::BareSkinTask(Options options, ReconNet teacher, ReconNet student, FaceRenderer renderer,
                           CoeffLayout layout)
    : options_(std::move(options)),
      teacher_(std::move(teacher)),
      student_(std::move(student)),
      renderer_(std::move(renderer)),
      layout_(layout),
      nets_(std::make_shared<Nets>()) {
  options_.check();
  nets_->G = std::dynamic_pointer_cast<nets::UNetImpl>(
      nets::find_model("unet256").make(generator_options(options_.g, options_.size, options_.head)));
  nlohmann::json d = nets::find_model("patchgan").defaults;
  d.update(options_.d);
  nets_->D = std::dynamic_pointer_cast<nets::PatchGANImpl>(nets::find_model("patchgan").make(d));
  BS_CHECK(nets_->G && nets_->D, "the zoo's unet256 / patchgan have unexpected types");
  if (options_.head != "image") nets::zero_last_layer(*nets_->G);
  if (options_.ema > 0) {
    // The average's net is made with the random stream put back afterwards, so that everything drawn later (the
    // LPIPS trunk, dropout) is the same with and without --ema-g: the average never changes how G trains.
    at::Generator rng = at::detail::getDefaultCPUGenerator();
    const at::Tensor rng_state = rng.get_state();
    nets_->G_ema = std::make_shared<GeneratorEmaImpl>(std::dynamic_pointer_cast<nets::UNetImpl>(
        nets::find_model("unet256").make(generator_options(options_.g, options_.size, options_.head))));
    rng.set_state(rng_state);
    reset_ema();
  }
  nets_->gan = losses::parse_gan_kind(options_.gan, "gan");
  if (options_.w3 > 0) nets_->lpips = losses::Lpips(options_.lpips_trunk, options_.face_api);
  if (options_.stage == 2) {
    if (!teacher_.module || !renderer_)
      throw InvalidInput("stage 2", "needs the teacher F and the 3DMM renderer", "give --teacher RUN and --model");
    if (options_.recon == "E" && !student_.module)
      throw InvalidInput("stage 2", "with recon E needs the student E", "build E or use recon F");
    for (auto& p : teacher_.module->parameters()) p.set_requires_grad(options_.recon == "F" && options_.tune_f);
  }
}

std::shared_ptr<torch::nn::Module> BareSkinTask::generator() const { return nets_->G; }

std::shared_ptr<torch::nn::Module> BareSkinTask::generator_ema() const {
  return nets_->G_ema ? nets_->G_ema->G : nullptr;
}

int64_t BareSkinTask::ema_updates() const { return nets_->G_ema ? nets_->G_ema->updates.item<int64_t>() : 0; }

void BareSkinTask::reset_ema() {
  if (!nets_->G_ema) return;
  nets_->G_ema->to(nets_->G->parameters().front().device());
  ema_update(*nets_->G_ema->G, *nets_->G, 0);
  torch::NoGradGuard no_grad;
  nets_->G_ema->updates.zero_();
}

std::map<std::string, std::shared_ptr<torch::nn::Module>> BareSkinTask::modules() {
  std::map<std::string, std::shared_ptr<torch::nn::Module>> m{{"G", nets_->G}, {"D", nets_->D}};
  if (nets_->G_ema) m["G_ema"] = nets_->G_ema;
  if (options_.stage == 2) {
    m["F"] = teacher_.module;
    if (options_.recon == "E") m["E"] = student_.module;
  }
  return m;
}

std::vector<train::OptimizerSpec> BareSkinTask::optimizers() {
  train::OptimizerSpec d{"D", "adam", {{"D", nets_->D->parameters(), options_.lr_d}}};
  train::OptimizerSpec g{"G", "adam", {{"G", nets_->G->parameters(), options_.lr_g}}};
  if (options_.stage == 2 && options_.recon == "E") g.groups.push_back({"E", student_.module->parameters(), options_.lr_e});
  if (options_.stage == 2 && options_.recon == "F" && options_.tune_f)
    g.groups.push_back({"F", teacher_.module->parameters(), options_.lr_f});
  for (auto* s : {&d, &g}) {
    s->beta1 = options_.beta1;
    s->beta2 = options_.beta2;
    s->schedule = train::Schedule::linear_from(options_.lr_decay, stage_steps_);
  }
  return {d, g};
}

torch::Tensor area_resized(const torch::Tensor& t, int64_t s) {
  if (t.size(-1) == s && t.size(-2) == s) return t;
  return F::interpolate(t, F::InterpolateFuncOptions().size(std::vector<int64_t>{s, s}).mode(torch::kArea));
}

torch::Tensor BareSkinTask::member(const data::Batch& batch, const std::string& name) const {
  const torch::Tensor& t = batch.at(name);
  const int64_t s = options_.size;
  if (name == "landmarks") {
    const double scale = double(s) / double(batch.at("makeup").size(-1));
    return t * scale;
  }
  return area_resized(t, s);
}

torch::Tensor BareSkinTask::generate(const torch::Tensor& images) {
  return generator_forward(*nets_->G, images, options_.head);
}

torch::Tensor BareSkinTask::generate_eval(const torch::Tensor& images) {
  return generator_forward(nets_->G_ema ? *nets_->G_ema->G : *nets_->G, images, options_.head);
}

torch::Tensor BareSkinTask::target(const data::Batch& batch) const {
  if (options_.target != "bare") return member(batch, options_.target);
  // The bare albedo is defined on the face only (black elsewhere): outside the face region (face.png: the face mesh,
  // not occluded) G is asked to keep its input, so the background does not dominate the L1.
  // Composed at the shards' size, then resized: on the face's outline a pixel of G's size is part face, part hair or
  // background, and so is its target (composed from the resized members, the face's coverage counted twice there).
  const torch::Tensor& face = batch.at("face");
  return area_resized(face * batch.at("bare") + (1 - face) * batch.at("makeup"), options_.size);
}

train::Losses BareSkinTask::loss(size_t phase, const data::Batch& batch) {
  if (teacher_.module) teacher_.module->eval();  // frozen batch statistics (also when tuned: batch 4 is too small)
  auto makeup = member(batch, "makeup");
  auto target = this->target(batch);
  auto D = [&](const torch::Tensor& out) { return nets_->D->forward(torch::cat({makeup * 2 - 1, out * 2 - 1}, 1)); };
  if (phase == 0 && nets_->G_ema) {  // G as the previous step left it joins the average
    torch::NoGradGuard no_grad;
    auto& n = nets_->G_ema->updates;
    ema_update(*nets_->G_ema->G, *nets_->G, ema_decay(options_.ema, n.item<int64_t>()));
    n.add_(1);
  }
  if (phase == 0) {  // D: real pairs vs G's output
    cached_output_ = generate(makeup);
    auto fake = cached_output_.detach();
    auto real = losses::gan_loss(D(target), true, nets_->gan, true);
    auto faked = losses::gan_loss(D(fake), false, nets_->gan, true);
    return {{"gan", options_.w2 * 0.5 * (real + faked)}};
  }
  torch::Tensor out = cached_output_.defined() ? cached_output_ : generate(makeup);
  cached_output_ = torch::Tensor();
  train::Losses l;
  for (auto& p : nets_->D->parameters()) p.set_requires_grad(false);
  l["l1"] = options_.w1 * losses::l1(out, target);
  l["gan"] = options_.w2 * losses::gan_loss(D(out), true, nets_->gan, false);
  for (auto& p : nets_->D->parameters()) p.set_requires_grad(true);
  if (options_.w3 > 0) l["lpips"] = options_.w3 * nets_->lpips->forward(out, target).mean();
  if (options_.w_level > 0) l["level"] = options_.w_level * level_loss(out, target, member(batch, "face"));
  if (options_.w_makeup > 0)
    l["makeup"] = options_.w_makeup * losses::masked_l1(out, target, makeup_region(makeup, member(batch, "before"),
                                                                                   member(batch, "face")));
  if (options_.stage == 1) return l;

  auto before = member(batch, "before");
  torch::Tensor reference;
  {
    torch::NoGradGuard no_grad;
    reference = teacher_.forward(before);
  }
  const int64_t k = layout_.size();  // without γ
  auto c_teacher = reference.narrow(1, 0, k), gamma = reference.narrow(1, k, 27);
  auto c_hat = (options_.recon == "E" ? student_.forward(out) : teacher_.forward(out)).narrow(1, 0, k);
  FaceRender r = renderer_(c_hat, gamma, options_.size);
  auto region = r.mask * whole_footprint(member(batch, "face"));  // pixels whose photo is all face
  l["diff"] = options_.w_diff * diff_loss(r.unlit, srgb_to_linear(out), region, options_.diff_gain);
  if (options_.w_light > 0) l["light"] = options_.w_light * light_loss(r.lit, srgb_to_linear(before), region);
  l["land"] = options_.w_land * landmark_loss(r.landmarks, member(batch, "landmarks"), 256.0 / double(options_.size));
  if (options_.recon == "E") l["coeff"] = options_.w_coeff * coeff_loss(c_hat, c_teacher);
  l["reg"] = options_.w_reg * reg_loss(c_hat, layout_);
  return l;
}

std::map<std::string, double> BareSkinTask::evaluate(const data::Batch& batch) {
  auto out = generate_eval(member(batch, "makeup"));
  auto skin = whole_footprint(member(batch, "skin"));
  const auto face = batch.tensors.count("face") ? member(batch, "face") : torch::Tensor();
  std::map<std::string, double> m;
  for (const char* truth : {"bare", "before"}) {
    if (!batch.tensors.count(truth)) continue;
    auto t = member(batch, truth);
    m[std::string("psnr_") + truth] = masked_psnr(out, t, skin).mean().item<double>();
    m[std::string("psnr_input_") + truth] = masked_psnr(member(batch, "makeup"), t, skin).mean().item<double>();
    m[std::string("ssim_") + truth] = masked_ssim(out, t, skin, truth_domain(truth, face)).mean().item<double>();
  }
  return m;
}

std::vector<std::vector<torch::Tensor>> BareSkinTask::samples(const data::Batch& batch) {
  auto makeup = member(batch, "makeup");
  auto out = generate_eval(makeup);
  std::vector<std::vector<torch::Tensor>> rows;
  for (int64_t i = 0; i < std::min<int64_t>(batch.size(), 4); ++i) {
    std::vector<torch::Tensor> row{makeup[i], out[i], target(batch)[i]};
    if (options_.target != "bare" && batch.tensors.count("bare")) row.push_back(member(batch, "bare")[i]);
    rows.push_back(row);
  }
  return rows;
}


FaceRenderer model_renderer(std::shared_ptr<const recon::FaceModel> model) {
  return [model](const torch::Tensor& coeff, const torch::Tensor& gamma, int64_t size) {
    recon::FaceRender r = model->render(coeff, recon::canonical_camera(int(size)), gamma);
    return FaceRender{r.colour, r.albedo, r.mask, r.landmarks};
  };
}

void start_from_stage1(BareSkinTask& task, const std::string& stage1_checkpoint) {
  auto modules = task.modules();
  train::load_module_weights(stage1_checkpoint, "G", *modules.at("G"));
  train::load_module_weights(stage1_checkpoint, "D", *modules.at("D"));
  task.reset_ema();
}

namespace {

// The first object in a run's configuration that holds `key` (the recon run's net options sit somewhere inside).
const nlohmann::json* find_object_with(const nlohmann::json& j, const std::string& key) {
  if (!j.is_object()) return nullptr;
  if (j.contains(key)) return &j;
  for (auto& [k, v] : j.items())
    if (const nlohmann::json* found = find_object_with(v, key)) return found;
  return nullptr;
}

ReconNet wrap(recon::ReconNet net, int64_t input_size) {
  ReconNet r;
  r.module = net.ptr();
  r.forward = [net, input_size](const torch::Tensor& image) mutable {
    torch::Tensor x = image;
    if (input_size > 0 && image.size(-1) != input_size)
      x = F::interpolate(image, F::InterpolateFuncOptions()
                                    .size(std::vector<int64_t>{input_size, input_size})
                                    .mode(torch::kBilinear)
                                    .align_corners(false));
    return net->forward(x);
  };
  return r;
}

}  // namespace

std::string check_teacher(const std::string& run) {
  namespace fs = std::filesystem;
  const std::string path = fs::is_directory(run) ? train::checkpoint_path(run) : run;
  const std::string hint = "give --teacher the run folder of 'bareskin train recon' (the teacher F)";
  if (!fs::exists(path)) throw IoError(path, "does not exist", hint);
  SafeTensors file = SafeTensors::open(path);
  auto it = file.metadata().find("bareskin.checkpoint");
  if (it == file.metadata().end()) throw InvalidInput(path, "is not a training checkpoint", hint);
  const nlohmann::json meta = nlohmann::json::parse(it->second, nullptr, false);
  if (!meta.is_object()) throw InvalidInput(path, "has unreadable checkpoint metadata", hint);
  const std::string task = meta.value("task", "");
  if (task != "recon") throw InvalidInput(path, "is a checkpoint of '" + task + "', not of the teacher F (recon)", hint);
  bool has_f = false;
  for (const auto& name : file.names()) has_f = has_f || name.rfind("module.F.", 0) == 0;
  if (!has_f) throw InvalidInput(path, "holds no teacher F (a student E run?)", hint);
  return path;
}

ReconNet load_teacher(const std::string& run, const recon::FaceModel& model) {
  const std::string path = check_teacher(run);
  const nlohmann::json meta =
      nlohmann::json::parse(SafeTensors::open(path).metadata().at("bareskin.checkpoint"), nullptr, false);
  const nlohmann::json config = meta.value("config", nlohmann::json::object());
  recon::ReconNetOptions net_options;
  if (const nlohmann::json* o = find_object_with(config, "arch")) recon::from_json(*o, net_options);
  net_options.gamma = true;
  int64_t image_size = 256;
  if (const nlohmann::json* o = find_object_with(config, "image_size")) image_size = o->at("image_size").get<int64_t>();
  recon::ReconNet net(net_options, model.layout(true));
  train::load_module_weights(path, "F", *net);
  net->eval();
  return wrap(net, image_size);
}

ReconNet make_student(const recon::FaceModel& model, const nlohmann::json& options) {
  recon::ReconNetOptions o;
  o.arch = "resnet18";
  o.gamma = false;
  nlohmann::json j = o;
  j.update(options);
  recon::from_json(j, o);
  o.gamma = false;
  return wrap(recon::ReconNet(o, model.layout(false)), 0);
}

std::vector<std::string> required_members(const Options& o) {
  std::vector<std::string> r{"makeup.png", o.target + ".png", "skin.png", "json"};
  if (o.target != "before") r.push_back("before.png");
  if (o.stage == 2 || o.target == "bare" || o.w_level > 0 || o.w_makeup > 0 || o.makeup_paint > 0)
    r.push_back("face.png");
  if (o.makeup_paint > 0 && o.target != "bare") r.push_back("bare.png");  // the light the paint is lit by
  return r;
}

namespace {
// The keys of RunOptions a run's configuration records (core/json_options.h); the folders, the trainer's options and
// the decode threads are not part of it.
const auto kRunFields = [](auto& v, auto& o) {
  v("task", o.task);
  v("train_data", o.train_data);
  v("val_data", o.val_data);
  v("steps1", o.steps1);
  v("steps2", o.steps2);
  v("batch", o.batch);
  v("seed", o.seed);
  v("teacher", o.teacher);
  v("model", o.model);
  v.unless_default("profile", o.profile);  // older runs have none
};
}  // namespace

void to_json(nlohmann::json& j, const RunOptions& o) { json_options::write(j, o, kRunFields); }

namespace {

train::TrainResult run_stage(const RunOptions& ro, BareSkinTask& task, const std::string& dir, int64_t steps) {
  data::LoaderOptions lo;
  lo.dataset = ro.train_data;
  lo.required = required_members(task.options());
  lo.batch_size = ro.batch;
  lo.seed = ro.seed;
  lo.decode_threads = ro.decode_threads;
  const double hue = task.options().makeup_hue, paint = task.options().makeup_paint;
  if (hue > 0 || paint > 0)
    lo.transform = [hue, paint](data::Example& e, uint64_t seed) {
      if (hue > 0) rotate_makeup_hue(e, seed, hue);
      if (paint > 0) paint_makeup(e, seed ^ 0x5eed0fa1a7ULL, paint);  // a draw of its own beside the hue's
    };
  data::ShardLoader train_loader(dist::this_rank(lo));
  if (!ro.trainer.resume) {  // a corrupt first batch fails before the run folder is made
    train_loader.next();
    train_loader.seek({0, 0});
  }
  std::unique_ptr<data::ShardLoader> val;
  if (!ro.val_data.empty()) {
    data::LoaderOptions vo = lo;
    vo.dataset = ro.val_data;
    vo.shuffle_buffer = 0;
    vo.transform = nullptr;  // validated on the world's own makeup
    val = std::make_unique<data::ShardLoader>(vo);
  }
  train::TrainerOptions to = ro.trainer;
  to.run_dir = dir;
  to.steps = steps;
  to.clip_grad_norm = task.options().clip_grad_norm;
  to.config = ro;
  to.config["stage"] = task.options().stage;
  for (const char* key : {"steps1", "steps2", "val_data", "profile"}) to.resumable_keys.push_back(key);
  task.set_stage_steps(steps);
  train::Trainer trainer(to, task, train_loader, val.get());
  return trainer.run();
}

}  // namespace

void RunOptions::check() const {
  task.check();
  if (train_data.empty()) throw InvalidInput("--data", "names no training split", "give the folder 'bareskin texgen faces' wrote");
  if (run_dir.empty()) throw InvalidInput("-o", "names no run folder", "give the run's output folder");
  if (steps1 < 1) throw InvalidInput("--steps1", "must be at least 1", "e.g. --steps1 1500");
  if (steps2 < 0) throw InvalidInput("--steps2", "must not be negative", "0 runs stage 1 only");
  data::LoaderOptions loader;  // the batch and the decode threads, as the loader checks them
  loader.batch_size = batch;
  loader.decode_threads = decode_threads;
  loader.check();
  train::TrainerOptions stage = trainer;  // its run folder and steps are set per stage
  stage.run_dir = run_dir;
  stage.steps = steps1;
  stage.check();
}

RunResult train_two_stages(const RunOptions& ro, const std::function<Stage2Parts()>& make_parts) {
  ro.check();
  RunResult result;
  const std::string dir1 = ro.run_dir + "/stage1", dir2 = ro.run_dir + "/stage2";
  const std::string ck1 = train::checkpoint_path(dir1), ck2 = train::checkpoint_path(dir2);
  namespace fs = std::filesystem;
  const bool done1 = ro.trainer.resume && fs::exists(ck1) && train::read_checkpoint_step(ck1) >= ro.steps1;
  if (!done1) {
    Options o = ro.task;
    o.stage = 1;
    train::seed_everything(ro.seed);
    BareSkinTask task(o);
    RunOptions r1 = ro;
    r1.trainer.resume = ro.trainer.resume && fs::exists(ck1);
    result.stage1 = run_stage(r1, task, dir1, ro.steps1);
    if (result.stage1.steps < ro.steps1) return result;  // stopped by a signal
  }
  if (ro.steps2 <= 0) return result;
  Options o = ro.task;
  o.stage = 2;
  train::seed_everything(ro.seed + 1);
  Stage2Parts parts = make_parts();
  BareSkinTask task(o, parts.teacher, parts.student, parts.renderer, parts.layout);
  RunOptions r2 = ro;
  r2.trainer.resume = ro.trainer.resume && fs::exists(ck2);
  if (!r2.trainer.resume) start_from_stage1(task, ck1);
  result.stage2 = run_stage(r2, task, dir2, ro.steps2);
  return result;
}

}  // namespace bareskin::bsn
