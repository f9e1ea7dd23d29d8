#include "training/bareskinnet.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "training/checkpoint.h"
#include "core/safetensors.h"
#include "training/lpips.h"
#include "training/recon.h"
#include "training/tensor_io.h"
#include "render/torch/ops.h"
#include "training/nets/patchgan.h"
#include "training/nets/unet.h"
#include "training/nets/zoo.h"
#include "training/ssim.h"

namespace bareskin::bsn {
namespace F = torch::nn::functional;

void to_json(nlohmann::json& j, const Options& o) {
  j = {{"stage", o.stage},       {"target", o.target},   {"size", o.size},       {"g", o.g},
       {"d", o.d},               {"gan", o.gan},         {"lpips_trunk", o.lpips_trunk},
       {"w1", o.w1},             {"w2", o.w2},           {"w3", o.w3},           {"w_coeff", o.w_coeff},
       {"w_land", o.w_land},     {"w_diff", o.w_diff},   {"w_light", o.w_light}, {"w_reg", o.w_reg},
       {"recon", o.recon},       {"tune_f", o.tune_f},   {"lr_g", o.lr_g},       {"lr_d", o.lr_d},
       {"lr_e", o.lr_e},         {"lr_f", o.lr_f},       {"beta1", o.beta1},     {"beta2", o.beta2}};
}

void from_json(const nlohmann::json& j, Options& o) {
  Options d;
  o.stage = j.value("stage", d.stage);
  o.target = j.value("target", d.target);
  o.size = j.value("size", d.size);
  o.g = j.value("g", d.g);
  o.d = j.value("d", d.d);
  o.gan = j.value("gan", d.gan);
  o.lpips_trunk = j.value("lpips_trunk", d.lpips_trunk);
  o.w1 = j.value("w1", d.w1);
  o.w2 = j.value("w2", d.w2);
  o.w3 = j.value("w3", d.w3);
  o.w_coeff = j.value("w_coeff", d.w_coeff);
  o.w_land = j.value("w_land", d.w_land);
  o.w_diff = j.value("w_diff", d.w_diff);
  o.w_light = j.value("w_light", d.w_light);
  o.w_reg = j.value("w_reg", d.w_reg);
  o.recon = j.value("recon", d.recon);
  o.tune_f = j.value("tune_f", d.tune_f);
  o.lr_g = j.value("lr_g", d.lr_g);
  o.lr_d = j.value("lr_d", d.lr_d);
  o.lr_e = j.value("lr_e", d.lr_e);
  o.lr_f = j.value("lr_f", d.lr_f);
  o.beta1 = j.value("beta1", d.beta1);
  o.beta2 = j.value("beta2", d.beta2);
  o.face_api = j.value("face_api", d.face_api);
  if (o.stage != 1 && o.stage != 2) throw InvalidInput("stage " + std::to_string(o.stage), "is not a stage", "use 1 or 2");
  if (o.target != "before" && o.target != "bare")
    throw InvalidInput("target '" + o.target + "'", "is not a target", "use before (the paper) or bare");
  if (o.recon != "E" && o.recon != "F")
    throw InvalidInput("recon '" + o.recon + "'", "is not a reconstruction network", "use E (the paper) or F");
  if (o.size < 32 || (o.size & (o.size - 1)) != 0)
    throw InvalidInput("size " + std::to_string(o.size), "is not a power of two ≥ 32", "use 64, 128 or 256");
  losses::parse_gan_kind(o.gan, "gan");
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

torch::Tensor srgb_to_linear(const torch::Tensor& x) {
  auto c = x.clamp(0, 1);
  return torch::where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055).clamp_min(1e-6).pow(2.4));
}

torch::Tensor diff_loss(const torch::Tensor& unlit, const torch::Tensor& g_out_linear, const torch::Tensor& mask) {
  return losses::masked_l1(unlit, g_out_linear, mask);
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

torch::Tensor masked_psnr(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask) {
  auto m = mask.expand_as(a);
  auto mse = ((a - b).pow(2) * m).sum({1, 2, 3}) / m.sum({1, 2, 3}).clamp_min(1);
  return 10 * torch::log10(1.0 / mse.clamp_min(1e-12));
}

torch::Tensor masked_ssim(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask) {
  losses::SsimOptions o;
  auto map = losses::ssim_map(a, b, o).mean(1, true);  // [B, 1, H − w + 1, W − w + 1]
  const int64_t r = o.window / 2;
  auto m = mask.narrow(2, r, map.size(2)).narrow(3, r, map.size(3));
  return (map * m).sum({1, 2, 3}) / m.sum({1, 2, 3}).clamp_min(1);
}

nlohmann::json generator_options(const nlohmann::json& g, int64_t size) {
  nlohmann::json o = nets::find_model("unet256").defaults;
  o["num_downs"] = std::max(5, int(std::lround(std::log2(double(size)))));
  o.update(g);
  return o;
}

struct BareSkinTask::Nets {
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
  nets_->G = std::dynamic_pointer_cast<nets::UNetImpl>(
      nets::find_model("unet256").make(generator_options(options_.g, options_.size)));
  nlohmann::json d = nets::find_model("patchgan").defaults;
  d.update(options_.d);
  nets_->D = std::dynamic_pointer_cast<nets::PatchGANImpl>(nets::find_model("patchgan").make(d));
  BS_CHECK(nets_->G && nets_->D, "the zoo's unet256 / patchgan have unexpected types");
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

std::map<std::string, std::shared_ptr<torch::nn::Module>> BareSkinTask::modules() {
  std::map<std::string, std::shared_ptr<torch::nn::Module>> m{{"G", nets_->G}, {"D", nets_->D}};
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
  }
  return {d, g};
}

torch::Tensor BareSkinTask::member(const data::Batch& batch, const std::string& name) const {
  const torch::Tensor& t = batch.at(name);
  const int64_t s = options_.size;
  if (name == "landmarks") {
    const double scale = double(s) / double(batch.at("makeup").size(-1));
    return t * scale;
  }
  if (t.size(-1) == s && t.size(-2) == s) return t;
  return F::interpolate(t, F::InterpolateFuncOptions().size(std::vector<int64_t>{s, s}).mode(torch::kArea));
}

torch::Tensor BareSkinTask::generate(const torch::Tensor& images) {
  return (nets_->G->forward(images * 2 - 1) + 1) * 0.5;
}

train::Losses BareSkinTask::loss(size_t phase, const data::Batch& batch) {
  if (teacher_.module) teacher_.module->eval();  // frozen batch statistics (also when tuned: batch 4 is too small)
  auto makeup = member(batch, "makeup");
  auto target = member(batch, options_.target);
  auto D = [&](const torch::Tensor& out) { return nets_->D->forward(torch::cat({makeup * 2 - 1, out * 2 - 1}, 1)); };
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
  auto region = r.mask * member(batch, "face");
  l["diff"] = options_.w_diff * diff_loss(r.unlit, srgb_to_linear(out), region);
  if (options_.w_light > 0) l["light"] = options_.w_light * light_loss(r.lit, srgb_to_linear(before), region);
  l["land"] = options_.w_land * landmark_loss(r.landmarks, member(batch, "landmarks"), 256.0 / double(options_.size));
  if (options_.recon == "E") l["coeff"] = options_.w_coeff * coeff_loss(c_hat, c_teacher);
  l["reg"] = options_.w_reg * reg_loss(c_hat, layout_);
  return l;
}

std::map<std::string, double> BareSkinTask::evaluate(const data::Batch& batch) {
  auto out = generate(member(batch, "makeup"));
  auto skin = member(batch, "skin");
  std::map<std::string, double> m;
  for (const char* truth : {"bare", "before"}) {
    if (!batch.tensors.count(truth)) continue;
    auto t = member(batch, truth);
    m[std::string("psnr_") + truth] = masked_psnr(out, t, skin).mean().item<double>();
    m[std::string("ssim_") + truth] = masked_ssim(out, t, skin).mean().item<double>();
  }
  return m;
}

std::vector<std::vector<torch::Tensor>> BareSkinTask::samples(const data::Batch& batch) {
  auto makeup = member(batch, "makeup");
  auto out = generate(makeup);
  std::vector<std::vector<torch::Tensor>> rows;
  for (int64_t i = 0; i < std::min<int64_t>(batch.size(), 4); ++i) {
    std::vector<torch::Tensor> row{makeup[i], out[i], member(batch, options_.target)[i]};
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
  if (o.stage == 2) r.push_back("face.png");
  return r;
}

void to_json(nlohmann::json& j, const RunOptions& o) {
  j = {{"task", o.task},     {"train_data", o.train_data}, {"val_data", o.val_data}, {"steps1", o.steps1},
       {"steps2", o.steps2}, {"batch", o.batch},           {"seed", o.seed},           {"teacher", o.teacher},
       {"model", o.model}};
}

namespace {

train::TrainResult run_stage(const RunOptions& ro, BareSkinTask& task, const std::string& dir, int64_t steps) {
  data::LoaderOptions lo;
  lo.dataset = ro.train_data;
  lo.required = required_members(task.options());
  lo.batch_size = ro.batch;
  lo.seed = ro.seed;
  lo.decode_threads = ro.decode_threads;
  data::ShardLoader train_loader(lo);
  if (!ro.trainer.resume) {  // a corrupt first batch fails before the run folder is made
    train_loader.next();
    train_loader.seek({0, 0});
  }
  std::unique_ptr<data::ShardLoader> val;
  if (!ro.val_data.empty()) {
    data::LoaderOptions vo = lo;
    vo.dataset = ro.val_data;
    vo.shuffle_buffer = 0;
    val = std::make_unique<data::ShardLoader>(vo);
  }
  train::TrainerOptions to = ro.trainer;
  to.run_dir = dir;
  to.steps = steps;
  to.config = ro;
  to.config["stage"] = task.options().stage;
  for (const char* key : {"steps1", "steps2", "val_data"}) to.resumable_keys.push_back(key);
  train::Trainer trainer(to, task, train_loader, val.get());
  return trainer.run();
}

}  // namespace

RunResult train_two_stages(const RunOptions& ro, const std::function<Stage2Parts()>& make_parts) {
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


// ---- Inference ----

namespace {

nlohmann::json checkpoint_config(const std::string& path) {
  SafeTensors file = SafeTensors::open(path);
  auto it = file.metadata().find("bareskin.checkpoint");
  nlohmann::json meta = it == file.metadata().end() ? nlohmann::json() : nlohmann::json::parse(it->second, nullptr, false);
  if (!meta.is_object() || meta.value("task", "") != kTaskName)
    throw InvalidInput(path, "is not a BareSkinNet checkpoint" + (meta.is_object() ? " (task '" + meta.value("task", "") + "')" : std::string()),
                       "give the run folder of 'bareskin train bareskin'");
  return meta.value("config", nlohmann::json::object());
}

torch::Tensor resized(const torch::Tensor& x, int64_t size, bool area) {
  if (x.size(-1) == size && x.size(-2) == size) return x;
  auto o = F::InterpolateFuncOptions().size(std::vector<int64_t>{size, size});
  if (area) return F::interpolate(x, o.mode(torch::kArea));
  return F::interpolate(x, o.mode(torch::kBilinear).align_corners(false));
}

torch::Tensor image_to_tensor(const Image& im) {
  return torch::from_blob(const_cast<float*>(im.pixels.data()), {im.height, im.width, im.channels}, torch::kFloat)
      .permute({2, 0, 1})
      .clone();
}

}  // namespace

namespace {

std::string run_checkpoint(const std::string& run) {
  namespace fs = std::filesystem;
  std::string path = run;
  if (fs::is_directory(run)) {
    path = train::checkpoint_path(run + "/stage2");
    if (!fs::exists(path)) path = train::checkpoint_path(run + "/stage1");
    if (!fs::exists(path)) path = train::checkpoint_path(run);
  }
  if (!fs::exists(path))
    throw IoError(run, "holds no BareSkinNet checkpoint (stage2/ or stage1/)", "give the run folder of 'bareskin train bareskin'");
  return path;
}

}  // namespace

Demakeup load_generator(const std::string& run, torch::Device device) {
  const std::string path = run_checkpoint(run);
  const nlohmann::json config = checkpoint_config(path);
  Options o;
  from_json(config.value("task", nlohmann::json::object()), o);
  Demakeup d;
  d.device = device;
  d.size = o.size;
  d.G = nets::find_model("unet256").make(generator_options(o.g, o.size));
  train::load_module_weights(path, "G", *d.G);
  d.G->to(device);
  d.G->eval();
  return d;
}

Demakeup Demakeup::load(const std::string& run, const std::string& teacher, const std::string& model,
                        torch::Device device) {
  Demakeup d = load_generator(run, device);
  const nlohmann::json config = checkpoint_config(run_checkpoint(run));
  const std::string teacher_run = teacher.empty() ? config.value("teacher", "") : teacher;
  const std::string model_path = model.empty() ? config.value("model", "") : model;
  if (teacher_run.empty() || model_path.empty())
    throw InvalidInput(run, "does not name its teacher F and model", "give --teacher and --model");
  Demakeup m = with_model(model_path, device);
  d.model = m.model;
  d.uvs = m.uvs;
  d.uv_triangles = m.uv_triangles;
  d.uv_vertex = m.uv_vertex;
  d.F = load_teacher(teacher_run, *d.model);
  d.F.module->to(device);
  d.F.module->eval();
  return d;
}

Demakeup Demakeup::with_model(const std::string& model_path, torch::Device device) {
  Demakeup d;
  d.device = device;
  d.model = std::make_shared<recon::FaceModel>(recon::FaceModel::load(model_path).to(device));
  SafeTensors file = SafeTensors::open(model_path);
  d.uvs = to_tensor(file.tensor("uvs"), model_path).to(torch::kFloat).to(device);
  d.uv_triangles = to_tensor(file.tensor("uv_triangles"), model_path).to(torch::kLong).to(device);
  const torch::Tensor tri = to_tensor(file.tensor("triangles"), model_path).to(torch::kLong).to(device);
  d.uv_vertex = torch::zeros({d.uvs.size(0)}, torch::TensorOptions().dtype(torch::kLong).device(device));
  d.uv_vertex.index_put_({d.uv_triangles.flatten()}, tri.flatten());
  return d;
}

void to_json(nlohmann::json& j, const EvalResult& r) {
  j = {{"samples", r.samples}, {"ms_per_image", r.ms_per_image}, {"mean", r.mean}, {"by_style", r.by_style}};
}

EvalResult evaluate_generator(const Demakeup& d, const std::string& split, const EvalOptions& eo) {
  torch::NoGradGuard no_grad;
  data::LoaderOptions lo;
  lo.dataset = split;
  lo.required = {"makeup.png", "before.png", "bare.png", "skin.png", "json"};
  lo.batch_size = eo.batch;
  lo.shuffle_buffer = 0;
  data::ShardLoader loader(lo);
  const int64_t total = eo.max_samples > 0 ? std::min(eo.max_samples, loader.epoch_size()) : loader.epoch_size();
  losses::Lpips lpips{nullptr};
  if (!eo.lpips_trunk.empty()) lpips = losses::Lpips(eo.lpips_trunk, eo.face_api);
  if (lpips) lpips->to(eo.device);
  detect::FaceRecognitionNet face{nullptr};
  if (!eo.face_api.empty()) face = detect::FaceRecognitionNet(eo.face_api);
  if (face) face->to(eo.device);
  std::map<std::string, double> sums;
  std::map<std::string, std::map<std::string, double>> style_sums;
  std::map<std::string, int64_t> style_counts;
  EvalResult r;
  while (r.samples < total) {
    data::Batch batch = loader.next();
    const int64_t n = std::min(batch.size(), total - r.samples);
    // At G's own resolution (the shards' images area-resized; the skin mask kept where at least half covered).
    auto take = [&](const std::string& name) { return resized(batch.at(name).narrow(0, 0, n).to(eo.device), d.size, true); };
    auto makeup = take("makeup");
    auto skin = (take("skin") >= 0.5).to(makeup.dtype());
    auto out = run_generator(d, makeup);
    std::map<std::string, torch::Tensor> m;  // per image [n]
    for (const char* truth : {"bare", "before"}) {
      auto t = take(truth);
      for (auto [name, x] : {std::pair<std::string, torch::Tensor>{"", out}, {"input_", makeup}}) {
        m["psnr_" + name + truth] = masked_psnr(x, t, skin);
        m["ssim_" + name + truth] = masked_ssim(x, t, skin);
        if (lpips) m["lpips_" + name + truth] = lpips->forward(x * skin, t * skin);
        if (face && std::string(truth) == "bare") {
          auto ea = F::normalize(face->forward(x), F::NormalizeFuncOptions().dim(1));
          auto eb = F::normalize(face->forward(t), F::NormalizeFuncOptions().dim(1));
          m["identity_" + name + truth] = (ea * eb).sum(1);
        }
      }
    }
    for (int64_t i = 0; i < n; ++i) {
      const std::string style = batch.meta[size_t(i)].value("style", "unknown");
      ++style_counts[style];
      for (auto& [name, v] : m) {
        const double x = v[i].item<double>();
        sums[name] += x;
        style_sums[style][name] += x;
      }
    }
    r.samples += n;
  }
  for (auto& [name, v] : sums) r.mean[name] = v / double(std::max<int64_t>(1, r.samples));
  for (auto& [style, ms] : style_sums)
    for (auto& [name, v] : ms) r.by_style[style][name] = v / double(style_counts[style]);
  r.by_style["count"] = {};
  for (auto& [style, c] : style_counts) r.by_style["count"][style] = double(c);
  // Inference time of G alone (batch 1, at its training size), median of 5 after a warm-up.
  auto G = std::dynamic_pointer_cast<nets::UNetImpl>(d.G);
  auto x = torch::rand({1, 3, d.size, d.size}, torch::TensorOptions().device(eo.device));
  std::vector<double> times;
  for (int k = 0; k < 6; ++k) {
    if (eo.device.is_cuda()) torch::cuda::synchronize();
    const auto t0 = std::chrono::steady_clock::now();
    G->forward(x);
    if (eo.device.is_cuda()) torch::cuda::synchronize();
    if (k) times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  r.ms_per_image = times[times.size() / 2];
  return r;
}

torch::Tensor run_generator(const Demakeup& d, const torch::Tensor& aligned) {
  torch::NoGradGuard no_grad;
  auto G = std::dynamic_pointer_cast<nets::UNetImpl>(d.G);
  BS_CHECK(G, "Demakeup::G is not a U-Net");
  auto x = resized(aligned.to(d.device), d.size, true);
  auto out = (G->forward(x * 2 - 1) + 1) * 0.5;
  return resized(out, aligned.size(-1), false).clamp(0, 1);
}

std::pair<torch::Tensor, torch::Tensor> unwarp_to_uv(const Demakeup& d, const torch::Tensor& images,
                                                     const torch::Tensor& coefficients, int64_t uv_size,
                                                     double depth_tolerance) {
  torch::NoGradGuard no_grad;
  const int64_t B = images.size(0), S = images.size(-1), R = uv_size;
  const recon::FaceModel& model = *d.model;
  auto posed = model.posed(model.split(coefficients));
  auto proj = recon::FaceModel::project(posed, recon::canonical_camera(int(S)));  // [B, V, 3]
  // The depth buffer of the face in the image.
  auto raster = render_torch::rasterize(proj, model.triangles(), S, S);
  auto depth = render_torch::interpolate(proj.narrow(2, 2, 1).contiguous(), proj, model.triangles(), raster);
  depth = torch::where(raster.triangle.unsqueeze(-1) >= 0, depth, torch::full_like(depth, 1e30)).permute({0, 3, 1, 2});
  // The surface point of every texel: the UV layout rasterized, the projected vertex positions interpolated.
  auto pos_uv = torch::stack({d.uvs.select(1, 0) * R, (1 - d.uvs.select(1, 1)) * R, torch::ones_like(d.uvs.select(1, 0))}, 1)
                    .unsqueeze(0).expand({B, -1, -1}).contiguous();
  auto uv_raster = render_torch::rasterize(pos_uv, d.uv_triangles, R, R);
  auto at = render_torch::interpolate(proj.index_select(1, d.uv_vertex), pos_uv, d.uv_triangles, uv_raster);  // [B,R,R,3]
  auto grid = torch::stack({at.select(3, 0) / double(S) * 2 - 1, at.select(3, 1) / double(S) * 2 - 1}, 3);
  auto sample = [&](const torch::Tensor& x, bool nearest) {
    auto o = F::GridSampleFuncOptions().padding_mode(torch::kBorder).align_corners(false);
    if (nearest) return F::grid_sample(x, grid, o.mode(torch::kNearest));
    return F::grid_sample(x, grid, o.mode(torch::kBilinear));
  };
  auto front = sample(depth, true);  // [B, 1, R, R]
  auto inside = (grid.abs() <= 1).all(3).unsqueeze(1);
  auto seen = ((uv_raster.triangle >= 0).unsqueeze(1) & inside &
               ((at.select(3, 2).unsqueeze(1) - front).abs() <= depth_tolerance)).to(images.dtype());
  return {sample(images.to(d.device), false) * seen, seen};
}

DemakeupResult demakeup(const Demakeup& d, const Image& photo, const detect::PhotoDetector& detector,
                        int64_t uv_size, const std::string& source) {
  auto faces = detector(photo);
  if (faces.empty()) throw InvalidInput(source, "no face was found", "give a photo with a face of at least ~80 px");
  DemakeupResult r;
  r.score = faces[0].score;
  r.landmarks = faces[0].points;
  const detect::Similarity sim = detect::alignment(faces[0].points);
  r.similarity = sim.matrix();
  Image aligned = detect::warp_aligned(photo, sim, detect::kAlignedSize);
  r.aligned = image_to_tensor(aligned).narrow(0, 0, 3).to(d.device);
  torch::NoGradGuard no_grad;
  r.bare = run_generator(d, r.aligned.unsqueeze(0))[0];
  auto c = d.F.forward(r.bare.unsqueeze(0));
  r.coefficients = c[0];
  auto render = d.model->render(c, recon::canonical_camera(detect::kAlignedSize));
  r.unlit = recon::linear_to_srgb(render.albedo)[0];
  r.mask = render.mask[0];
  auto [uv, seen] = unwarp_to_uv(d, r.bare.unsqueeze(0), c, uv_size);
  r.uv = uv[0];
  r.uv_mask = seen[0];
  return r;
}

}  // namespace bareskin::bsn
