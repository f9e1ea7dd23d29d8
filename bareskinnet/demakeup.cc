// BareSkinNet at inference (bareskinnet/bareskinnet.h, "Inference" and "Evaluation"): G, F and the 3DMM loaded from
// runs, a photo or an aligned face to bare skin, its fit and its UV unwrap, the written result files, and G's
// held-out evaluation (`evaluate_run`: a run's eval.json).
#include <algorithm>
#include <cmath>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <iostream>

#include "core/error.h"
#include "core/files.h"
#include "core/png.h"
#include "core/safetensors.h"
#include "detect/face_api.h"
#include "detect/face_recognition.h"
#include "render/torch/ops.h"
#include "bareskinnet/bareskinnet.h"
#include "training/checkpoint.h"
#include "training/lpips.h"
#include "recon/recon.h"
#include "training/tensor_io.h"
#include "training/nets/unet.h"
#include "training/nets/zoo.h"

namespace bareskin::bsn {
namespace F = torch::nn::functional;

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

torch::Tensor bilinear_resized(const torch::Tensor& x, int64_t size) {
  if (x.size(-1) == size && x.size(-2) == size) return x;
  return F::interpolate(x, F::InterpolateFuncOptions().size(std::vector<int64_t>{size, size}).mode(torch::kBilinear)
                               .align_corners(false));
}

}  // namespace

torch::Tensor image_tensor(const Image& im) {
  return torch::from_blob(const_cast<float*>(im.pixels.data()), {im.height, im.width, im.channels}, torch::kFloat)
      .permute({2, 0, 1})
      .clone();
}

namespace {

// train::run_checkpoint, which must exist.
std::string bareskin_checkpoint(const std::string& run) {
  const std::string path = train::run_checkpoint(run);
  if (!std::filesystem::exists(path))
    throw IoError(run, "holds no BareSkinNet checkpoint (stage2/ or stage1/)", "give the run folder of 'bareskin train bareskin'");
  return path;
}

}  // namespace

Demakeup load_generator(const std::string& run, torch::Device device) {
  const std::string path = bareskin_checkpoint(run);
  const nlohmann::json config = checkpoint_config(path);
  const Options o = options_of_run(config.value("task", nlohmann::json::object()));
  Demakeup d;
  d.device = device;
  d.size = o.size;
  d.head = o.head;
  d.maps_at_photo_size = o.target == "before" && o.head != "image";
  d.G = nets::find_model("unet256").make(generator_options(o.g, o.size, o.head));
  if (o.ema > 0) {  // the moving average the run kept
    GeneratorEmaImpl average(std::dynamic_pointer_cast<nets::UNetImpl>(d.G));
    BS_CHECK(average.G, "the zoo's unet256 has an unexpected type");
    train::load_module_weights(path, "G_ema", average);
  } else {
    train::load_module_weights(path, "G", *d.G);
  }
  d.G->to(device);
  d.G->eval();
  // The phase form of the upsampling pays off with LibTorch's CPU convolutions only; cuDNN has its own.
  auto inference = std::make_shared<nets::UNetInference>(*std::dynamic_pointer_cast<nets::UNetImpl>(d.G),
                                                         device.is_cpu() ? 8 : 0);
  d.G_inference = inference;
  return d;
}

Demakeup Demakeup::load(const std::string& run, const std::string& teacher, const std::string& model,
                        torch::Device device) {
  Demakeup d = load_generator(run, device);
  const nlohmann::json config = checkpoint_config(bareskin_checkpoint(run));
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

namespace {

// G's U-Net output for images x in [0, 1] (before the head, as generator_forward), through the inference form when
// there is one (InferenceMode only inside; what the head computes from it is an ordinary tensor).
torch::Tensor generator_maps(const Demakeup& d, const torch::Tensor& x) {
  if (!d.G_inference) {
    auto G = std::dynamic_pointer_cast<nets::UNetImpl>(d.G);
    BS_CHECK(G, "Demakeup::G is not a U-Net");
    return G->forward(x * 2 - 1);
  }
  torch::Tensor y;
  {
    c10::InferenceMode guard;
    y = d.G_inference->forward(x * 2 - 1);
  }
  return y;
}

}  // namespace

void to_json(nlohmann::json& j, const EvalResult& r) {
  j = {{"samples", r.samples}, {"ms_per_image", r.ms_per_image}, {"mean", r.mean}, {"by_style", r.by_style}};
}

namespace {

// A region's PSNR per image, NaN where the image has fewer than 16 of its pixels.
torch::Tensor region_psnr(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& region) {
  const auto p = masked_psnr(a, b, region);
  return torch::where(region.sum({1, 2, 3}) >= 16, p, torch::full_like(p, std::nan("")));
}

// The metrics beyond the skin mask, against the bare truth, for G's output and the input (the do-nothing baseline):
//  - face_*: the whole face region (face.png), lips, eyes and brows included;
//  - makeup_*: where the makeup changed the face (mean |makeup − before| over the channels > 0.02), the region the
//    skin mask leaves out; NaN for faces without makeup; against the bare truth and against the before image (the
//    makeup's own error: what the paper's G, trained towards the before image, removes);
//  - albedo_*: the albedo F fits to G's output (to the input for the baseline), rendered unlit, on the face region
//    F's render covers: what stage 2 trains G for (only when the run names its teacher F and model).
template <class Take>
void add_region_metrics(std::map<std::string, torch::Tensor>& m, const data::Batch& batch, int64_t n,
                        const Demakeup& d, const torch::Tensor& makeup, const torch::Tensor& out, const Take& take) {
  if (!batch.tensors.count("face")) return;
  auto bare = take("bare");
  auto face = whole_footprint(take("face"));
  auto changed = makeup_region(makeup, take("before"), face);
  for (auto [name, x] : {std::pair<std::string, torch::Tensor>{"", out}, {"input_", makeup}}) {
    m["psnr_face_" + name + "bare"] = masked_psnr(x, bare, face);
    m["ssim_face_" + name + "bare"] = masked_ssim(x, bare, face, face);
    m["psnr_makeup_" + name + "bare"] = region_psnr(x, bare, changed);
    m["psnr_makeup_" + name + "before"] = region_psnr(x, take("before"), changed);
  }
  if (!d.F.module || !d.model) return;
  // F and the render at the shards' size (256²), as demakeup runs them.
  auto full = [&](const std::string& key) { return batch.at(key).narrow(0, 0, n).to(d.device); };
  auto bare_full = full("bare");
  auto face_full = (full("face") >= 0.5).to(bare_full.dtype());
  for (auto [name, x] : {std::pair<std::string, torch::Tensor>{"", run_generator(d, full("makeup"))},
                         {"input_", full("makeup")}}) {
    auto render = d.model->render(d.F.forward(x), recon::canonical_camera(int(x.size(-1))));
    auto region = face_full * (render.mask >= 0.5).to(x.dtype());
    m["psnr_albedo_" + name + "bare"] = masked_psnr(recon::linear_to_srgb(render.albedo), bare_full, region);
  }
}

}  // namespace

namespace {
// "" (none), vgg16-random or facenet (training/lpips.h).
void check_lpips_trunk(const std::string& trunk) {
  if (!trunk.empty() && trunk != "vgg16-random" && trunk != "facenet")
    throw InvalidInput("--lpips", "'" + trunk + "' is not an LPIPS trunk", "use vgg16-random or facenet");
}
}  // namespace

void EvalOptions::check() const {
  check_lpips_trunk(lpips_trunk);
  if (batch < 1) throw InvalidInput("--batch", "must be at least 1", "give a positive batch size");
  if (max_samples < 0) throw InvalidInput("--eval-samples", "must not be negative", "0 takes every sample");
}

void RunEvalOptions::check() const {
  check_lpips_trunk(lpips_trunk);
  if (max_samples < 0) throw InvalidInput("--eval-samples", "must not be negative", "0 takes every sample");
}

EvalResult evaluate_generator(const Demakeup& d, const std::string& split, const EvalOptions& eo) {
  eo.check();
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
  std::map<std::string, int64_t> style_counts, counts;
  std::map<std::string, std::map<std::string, int64_t>> style_name_counts;
  EvalResult r;
  while (r.samples < total) {
    data::Batch batch = loader.next();
    const int64_t n = std::min(batch.size(), total - r.samples);
    // At G's own resolution (the shards' images area-resized; the skin where a pixel's whole footprint is skin).
    auto take = [&](const std::string& name) { return area_resized(batch.at(name).narrow(0, 0, n).to(eo.device), d.size); };
    auto makeup = take("makeup");
    auto skin = whole_footprint(take("skin"));
    const auto face_mask = batch.tensors.count("face") ? take("face") : torch::Tensor();
    auto out = run_generator(d, makeup);
    std::map<std::string, torch::Tensor> m;  // per image [n]; NaN where an image has none of a region
    for (const char* truth : {"bare", "before"}) {
      auto t = take(truth);
      for (auto [name, x] : {std::pair<std::string, torch::Tensor>{"", out}, {"input_", makeup}}) {
        m["psnr_" + name + truth] = masked_psnr(x, t, skin);
        m["ssim_" + name + truth] = masked_ssim(x, t, skin, truth_domain(truth, face_mask));
        if (lpips) m["lpips_" + name + truth] = lpips->forward(x * skin, t * skin);
        if (face && std::string(truth) == "bare") {
          auto ea = F::normalize(face->forward(x), F::NormalizeFuncOptions().dim(1));
          auto eb = F::normalize(face->forward(t), F::NormalizeFuncOptions().dim(1));
          m["identity_" + name + truth] = (ea * eb).sum(1);
        }
      }
    }
    add_region_metrics(m, batch, n, d, makeup, out, take);
    for (int64_t i = 0; i < n; ++i) {
      const std::string style = batch.meta[size_t(i)].value("style", "unknown");
      ++style_counts[style];
      for (auto& [name, v] : m) {
        const double x = v[i].item<double>();
        if (std::isnan(x)) continue;
        sums[name] += x;
        ++counts[name];
        style_sums[style][name] += x;
        ++style_name_counts[style][name];
      }
    }
    r.samples += n;
  }
  for (auto& [name, v] : sums) r.mean[name] = v / double(counts[name]);
  for (auto& [style, ms] : style_sums)
    for (auto& [name, v] : ms) r.by_style[style][name] = v / double(style_name_counts[style][name]);
  r.by_style["count"] = {};
  for (auto& [style, c] : style_counts) r.by_style["count"][style] = double(c);
  // Inference time of G alone (batch 1, at its training size), median of 5 after a warm-up.
  auto x = torch::rand({1, 3, d.size, d.size}, torch::TensorOptions().device(eo.device));
  std::vector<double> times;
  for (int k = 0; k < 6; ++k) {
    if (eo.device.is_cuda()) torch::cuda::synchronize();
    const auto t0 = std::chrono::steady_clock::now();
    run_generator(d, x);
    if (eo.device.is_cuda()) torch::cuda::synchronize();
    if (k) times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(times.begin(), times.end());
  r.ms_per_image = times[times.size() / 2];
  return r;
}

void evaluate_run(const std::string& run, const std::string& data, const RunEvalOptions& options) {
  namespace fs = std::filesystem;
  options.check();
  const std::string test_split = (fs::path(data) / "test").string();
  if (!fs::exists(fs::path(test_split) / "manifest.json")) {
    if (options.required)
      throw InvalidInput(data, "has no test/manifest.json to evaluate on", "give the folder 'bareskin texgen faces' wrote");
    return;
  }
  EvalOptions eo;
  eo.lpips_trunk = options.lpips_trunk;
  eo.device = options.device;
  eo.max_samples = options.max_samples;
  const std::string face_api = detect::default_face_api_folder();
  if (fs::exists(fs::path(face_api) / detect::kFaceRecognitionManifest)) eo.face_api = face_api;
  if (eo.lpips_trunk == "facenet" && eo.face_api.empty()) eo.lpips_trunk.clear();
  // With the run's teacher F and model (stage 2 runs name them), the albedo metrics too.
  const nlohmann::json config = checkpoint_config(bareskin_checkpoint(run));
  const bool with_f = fs::exists(config.value("teacher", "")) && fs::exists(config.value("model", ""));
  const Demakeup d = with_f ? Demakeup::load(run, "", "", options.device) : load_generator(run, options.device);
  const EvalResult r = evaluate_generator(d, test_split, eo);
  nlohmann::json j = r;
  j["lpips_trunk"] = eo.lpips_trunk;
  j["split"] = test_split;
  write_file_atomic(run + "/eval.json", j.dump(2) + "\n");
  if (!options.quiet)
    std::cerr << fmt::format("test ({} faces): skin PSNR {:.2f} dB / SSIM {:.4f} vs bare (input {:.2f} / {:.4f}); vs before {:.2f} dB; G {:.1f} ms\n",
                             r.samples, r.mean.at("psnr_bare"), r.mean.at("ssim_bare"), r.mean.at("psnr_input_bare"),
                             r.mean.at("ssim_input_bare"), r.mean.at("psnr_before"), r.ms_per_image);
}

namespace {

// One pass of G: its image at its size, upsampled; or its maps upsampled and applied to the photo
// (Demakeup::maps_at_photo_size).
torch::Tensor generator_image(const Demakeup& d, const torch::Tensor& full) {
  const int64_t S = full.size(-1);
  auto x = area_resized(full, d.size);
  auto y = generator_maps(d, x);
  if (!d.maps_at_photo_size) return bilinear_resized(apply_head(x, y, d.head), S).clamp(0, 1);
  return apply_head(full, bilinear_resized(y, S), d.head).clamp(0, 1);
}

}  // namespace

torch::Tensor run_generator(const Demakeup& d, const torch::Tensor& aligned) {
  torch::NoGradGuard no_grad;
  auto full = aligned.to(d.device);
  if (d.skip_g) return full.clamp(0, 1);
  if (!d.flip_average) return generator_image(d, full);
  return (generator_image(d, full) + generator_image(d, full.flip(-1)).flip(-1)) * 0.5;
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

namespace {

// Wall milliseconds since `t0`, restarting it (after the device's queue has run).
double lap(std::chrono::steady_clock::time_point& t0, torch::Device device) {
  if (device.is_cuda()) torch::cuda::synchronize();
  const auto t = std::chrono::steady_clock::now();
  const double ms = std::chrono::duration<double, std::milli>(t - t0).count();
  t0 = t;
  return ms;
}

}  // namespace

DemakeupResult demakeup_aligned(const Demakeup& d, const torch::Tensor& aligned, int64_t uv_size) {
  torch::NoGradGuard no_grad;
  DemakeupResult r;
  auto t0 = std::chrono::steady_clock::now();
  r.similarity << 1, 0, 0, 0, 1, 0;
  r.landmarks.setZero();
  r.aligned = aligned.narrow(0, 0, 3).to(d.device);
  r.bare = run_generator(d, r.aligned.unsqueeze(0))[0];
  r.ms["G"] = lap(t0, d.device);
  auto c = d.F.forward(r.bare.unsqueeze(0));
  r.coefficients = c[0];
  r.ms["F"] = lap(t0, d.device);
  auto render = d.model->render(c, recon::canonical_camera(int(r.aligned.size(-1))));
  r.unlit = recon::linear_to_srgb(render.albedo)[0];
  r.mask = render.mask[0];
  r.ms["render"] = lap(t0, d.device);
  auto [uv, seen] = unwarp_to_uv(d, r.bare.unsqueeze(0), c, uv_size);
  r.uv = uv[0];
  r.uv_mask = seen[0];
  r.ms["unwarp"] = lap(t0, d.device);
  return r;
}

DemakeupResult demakeup(const Demakeup& d, const Image& photo, const detect::PhotoDetector& detector,
                        int64_t uv_size, const std::string& source) {
  auto t0 = std::chrono::steady_clock::now();
  auto faces = detector(photo);
  if (faces.empty()) throw InvalidInput(source, "no face was found", "give a photo with a face of at least ~80 px");
  const double detect_ms = lap(t0, torch::kCPU);
  const detect::Similarity sim = detect::alignment(faces[0].points);
  Image aligned = detect::warp_aligned(photo, sim, detect::kAlignedSize);
  const double align_ms = lap(t0, torch::kCPU);
  DemakeupResult r = demakeup_aligned(d, image_tensor(aligned), uv_size);
  r.ms["detect"] = detect_ms;
  r.ms["align"] = align_ms;
  r.score = faces[0].score;
  r.landmarks = faces[0].points;
  r.similarity = sim.matrix();
  return r;
}

namespace {

Image to_image(const torch::Tensor& chw) {
  auto hwc = chw.detach().to(torch::kCPU, torch::kFloat).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image image(int(hwc.size(1)), int(hwc.size(0)), int(hwc.size(2)), ColorSpace::sRGB);
  std::memcpy(image.pixels.data(), hwc.data_ptr<float>(), image.pixels.size() * sizeof(float));
  return image;
}

void write_png(const std::string& path, const torch::Tensor& chw) { write_file_atomic(path, encode_png(to_image(chw))); }

}  // namespace

void write_demakeup(const DemakeupResult& r, const Demakeup& d, const std::string& dir, const std::string& photo,
                    bool detected) {
  make_directories(dir);
  write_png(dir + "/aligned.png", r.aligned);
  write_png(dir + "/bare.png", r.bare);
  write_png(dir + "/unlit.png", r.unlit * r.mask);
  write_png(dir + "/uv.png", r.uv);
  write_png(dir + "/uv_mask.png", r.uv_mask);
  nlohmann::json j = recon::coefficients_to_json(r.coefficients.to(torch::kCPU), d.model->layout(true));
  j["photo"] = photo;
  if (detected) {
    nlohmann::json lm = nlohmann::json::array();
    for (int i = 0; i < 68; ++i) lm.push_back({r.landmarks(i, 0), r.landmarks(i, 1)});
    j["detector_score"] = r.score;
    j["photo_landmarks"] = lm;
  }
  j["align"] = {{"similarity", {{r.similarity(0, 0), r.similarity(0, 1), r.similarity(0, 2)},
                                {r.similarity(1, 0), r.similarity(1, 1), r.similarity(1, 2)}}},
                {"source", detected ? "detector" : "given"}};
  const int64_t s = r.aligned.size(-1);
  j["camera"] = {{"focal", 1015.0 * double(s) / 224}, {"cx", s / 2}, {"cy", s / 2}, {"width", s}, {"height", s}};
  j["bareskinnet"] = !d.skip_g;
  write_file_atomic(dir + "/coefficients.json", j.dump(2) + "\n");
}

}  // namespace bareskin::bsn
