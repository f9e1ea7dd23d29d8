// `bareskin train recon`'s run: the teacher F or the student E trained on `texgen faces` samples (recon.h's task through
// the Trainer). No Torch in this header, so the command that fills it builds without the Torch precompiled header.
#pragma once
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "training/run_flags.h"

namespace bareskin::recon {

struct TrainReconOptions {
  std::string data;   // texgen faces: train/ (and val/) inside
  std::string model;  // the morphable model (model.safetensors)
  std::string output = "runs/F";
  std::string arch = "resnet50";                   // resnet50 (F), resnet18 (E), resnet34
  std::string supervision = "both", input = "before";
  std::string gamma = "auto";                      // on, off or auto (on for resnet50)
  nlohmann::json loss = nlohmann::json::object();  // loss weights over the defaults
  int width = 64, image_size = 0;                  // image_size 0: the samples'
  int pool_grid = 1;                               // the heads' grid over layer4 (1: global average)
  int64_t decay_every = 0;                         // 0: half the steps; -1: never
  int64_t eval_batches = 8;
  double lr = 1e-4;
  double colour_jitter = 0;   // jitter_colour's strength on the training samples (recon.h); 0: off
  double clip_grad_norm = 0;  // each step's gradients scaled to at most this norm, logged as <net>/grad_norm; 0: off
  // steps, batch, seed, device, ...: Deep3DFaceRecon's 20k steps of 8
  train::RunFlags trainer = [] {
    train::RunFlags f;
    f.steps = 20000;
    f.batch = 8;
    return f;
  }();
  bool progress = true;
  nlohmann::json profile;  // what apply_profile returned: recorded in the run's configuration
  void check() const;      // InvalidInput naming the flag
};

struct TrainReconResult {
  std::string module;  // the net's name
  int64_t steps = 0;
  std::map<std::string, double> last_eval;
};

// Trains into options.output (checkpoints, logs, config.json); resumes with options.resume. InvalidInput / IoError for
// a missing model, samples that are not square, a bad device or loss.
TrainReconResult train_recon(const TrainReconOptions& options);

}  // namespace bareskin::recon
