// `bareskin train bareskin`'s run: BareSkinNet's two stages (bareskinnet.h) on `texgen faces` samples with the teacher F
// of `bareskin train recon`, then the held-out evaluation (eval.json). No Torch in this header, so the command that fills
// it builds without the Torch precompiled header.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "bareskinnet/options.h"
#include "training/run_flags.h"

namespace bareskin::bsn {

struct TrainBareskinOptions {
  std::string data;     // texgen faces: train/ (val/, test/) inside
  std::string teacher;  // a `train recon` run (stage 2)
  std::string model;    // the morphable model the teacher was trained with (stage 2)
  std::string output = "runs/bsn";
  std::string ablation;  // a row of the paper's Fig. 7 (ablation_preset), or ""
  Options task;          // G's head, size, learning rates, ... (the flags over the defaults)
  // JSON objects over the defaults: G (unet256), D (patchgan), E (recon net) options, and loss weights (w1, w2, w3,
  // w_coeff, w_land, w_diff, w_light, w_reg, w_level).
  nlohmann::json g = nlohmann::json::object(), d = nlohmann::json::object(), student = nlohmann::json::object(),
                 weights = nlohmann::json::object();
  int64_t steps1 = 10000, steps2 = 30000;  // steps2 0: stage 1 only
  bool evaluate = false;                   // only evaluate the run in `output`
  int64_t eval_samples = 0;                // test samples of the evaluation (0: all)
  // batch, seed, device, ... (its steps are steps1 and steps2): the paper's batch of 4
  train::RunFlags trainer = [] {
    train::RunFlags f;
    f.batch = 4;
    return f;
  }();
  bool quiet = false;      // no progress, no summary on stderr
  nlohmann::json profile;  // what apply_profile returned: recorded in the run's configuration
  void check() const;      // InvalidInput naming the flag
};

// Trains the missing stages into options.output (stage1/, stage2/), then evaluates the run into eval.json (or only
// that with options.evaluate). InvalidInput / IoError before anything is written for bad options, a missing teacher or
// model, a wrong teacher checkpoint.
void train_bareskin(TrainBareskinOptions options);

}  // namespace bareskin::bsn
