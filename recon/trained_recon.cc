// A trained F/E for inference: loading a run and reconstructing aligned photos (recon/recon.h).
#include "recon/recon.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/files.h"
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

std::string run_model_path(const std::string& run, const std::string& model) {
  namespace fs = std::filesystem;
  if (!model.empty()) return model;
  // The run's config names the model it was trained with.
  const std::string ckpt = fs::is_directory(run) ? train::checkpoint_path(run) : run;
  if (!fs::exists(ckpt)) throw IoError(ckpt, "does not exist", "give --run the folder of 'bareskin train recon'");
  const std::string cfg = (fs::path(ckpt).parent_path() / "config.json").string();
  std::string path;
  if (fs::exists(cfg)) path = nlohmann::json::parse(read_file(cfg), nullptr, false).value("model", "");
  if (path.empty()) {
    throw InvalidInput(cfg, "is missing or names no model file (the one the run was trained with)",
                       "give --run the folder of 'bareskin train recon', or --model");
  }
  return path;
}

void ConfidenceOptions::check() const {
  if (!(landmark_px > 0 && std::isfinite(landmark_px)) || !(psnr_db > 0 && std::isfinite(psnr_db)))
    throw InvalidInput("confidence", "the landmark (px) and PSNR (dB) thresholds must be positive numbers",
                       "e.g. 4 px and 20 dB (default)");
}

Reconstruction reconstruct(const TrainedRecon& r, const torch::Tensor& aligned, const torch::Tensor& detected,
                           const ConfidenceOptions& co) {
  co.check();
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
