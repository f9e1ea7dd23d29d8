// What a Task asks of the Trainer's optimizers: Adam or AdamW over named parameter groups with their own rates, and
// the learning-rate schedule (training/trainer.h runs them; training/checkpoint.h saves and restores their state).
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace bareskin::train {

// Learning-rate factor over the steps: constant; "linear" (constant until decay_start, then linearly to 0 at
// `steps`, as pix2pixHD); "step" (x gamma every step_every steps, as Deep3DFaceRecon's x0.2).
struct Schedule {
  std::string kind = "constant";
  int64_t decay_start = 0;
  int64_t step_every = 0;
  double gamma = 0.2;
  double factor(int64_t step, int64_t steps) const;  // InvalidInput (check()) for an unknown kind
  void check() const;                                // InvalidInput for an unknown kind
  // The schedule of a `--lr-decay F` flag: constant for F = 1, else linear from F × steps (F, a fraction in [0, 1]).
  static Schedule linear_from(double fraction, int64_t steps);
};
void to_json(nlohmann::json& j, const Schedule& s);
void from_json(const nlohmann::json& j, Schedule& s);

struct ParamGroup {
  std::string name;
  std::vector<torch::Tensor> params;
  double lr = 1e-4;
};

// One optimizer: Adam or AdamW over named parameter groups with their own rates.
struct OptimizerSpec {
  std::string name;  // "G", "D", "E"
  std::string kind = "adam";
  std::vector<ParamGroup> groups;
  double beta1 = 0.9, beta2 = 0.999, eps = 1e-8, weight_decay = 0;
  Schedule schedule;
};

}  // namespace bareskin::train
