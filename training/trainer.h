// One training loop for every model of the toolkit. A model contributes a Task (its modules, optimizers and losses);
// the Trainer owns everything else: schedules, gradient clipping, the NaN stop, distributed gradient averaging,
// checkpoints that resume bit-identically, metrics (CSV, SVG charts, TensorBoard), sample grids, validation, and the
// progress bar. docs/training.md describes the run folder.
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "training/checkpoint.h"
#include "training/data.h"
#include "training/distributed.h"
#include "training/optimizer.h"

namespace bareskin::train {

using Losses = std::map<std::string, torch::Tensor>;  // named scalar terms, already weighted; their sum is minimised

class Task {
 public:
  virtual ~Task() = default;
  virtual std::string name() const = 0;
  // Every module whose state the checkpoint keeps (trained or frozen), by name.
  virtual std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() = 0;
  // The optimizers; one step runs one phase per optimizer, in this order (a GAN: "D" then "G", or the reverse).
  virtual std::vector<OptimizerSpec> optimizers() = 0;
  // The losses phase `phase` minimises on `batch` (called in train mode, with gradients).
  virtual Losses loss(size_t phase, const data::Batch& batch) = 0;
  // Validation metrics of one batch (called in eval mode without gradients); the Trainer averages them.
  virtual std::map<std::string, double> evaluate(const data::Batch& batch) { return {}; }
  // Picture rows for the run's sample grids: per row, images [3,H,W] in [0,1] (e.g. input, output, target).
  virtual std::vector<std::vector<torch::Tensor>> samples(const data::Batch& batch) { return {}; }
};

struct TrainerOptions {
  std::string run_dir;
  int64_t steps = 1000;
  int64_t log_every = 10;
  int64_t checkpoint_every = 500;
  int64_t eval_every = 500;  // 0: never
  int64_t eval_batches = 8;
  int64_t sample_every = 500;  // 0: never
  double clip_grad_norm = 0;   // 0: off
  bool resume = false;
  bool bf16 = true;  // autocast to bfloat16 on CUDA (ignored on the CPU)
  bool progress = true;
  torch::Device device = torch::kCPU;
  // The command's whole configuration: echoed to config.json; a resumed run must have the same one, except for the
  // keys in `resumable_keys` (steps, intervals, ...).
  nlohmann::json config = nlohmann::json::object();
  std::vector<std::string> resumable_keys = {"steps", "log_every", "checkpoint_every", "eval_every", "eval_batches",
                                             "sample_every", "resume", "progress", "threads"};
  // Brings the configuration a checkpoint stored, written by an earlier version, to this version's keys before the
  // comparison (a renamed option); empty: compared as stored.
  std::function<void(nlohmann::json&)> upgrade_config;
  void check() const;  // InvalidInput naming the flag
};

// InvalidInput naming the flag unless steps and log_every are >= 1 and the other intervals >= 0 (0: never): what
// TrainerOptions::check() and the trainings' run options check of their steps and intervals.
void check_intervals(int64_t steps, int64_t log_every, int64_t checkpoint_every, int64_t eval_every, int64_t sample_every);

// What a finished run reports.
struct TrainResult {
  int64_t steps = 0;
  std::map<std::string, double> last_losses;  // averaged over the last logging interval
  std::map<std::string, double> last_eval;
};

class Trainer {
 public:
  // `validation` may be null. `group` may be null (one process).
  Trainer(TrainerOptions options, Task& task, data::DataSource& train, data::DataSource* validation,
          dist::Group* group = nullptr);
  ~Trainer();
  TrainResult run();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// Seeds LibTorch's generators (call before the task builds its modules, so initial weights follow the seed).
void seed_everything(uint64_t seed);

}  // namespace bareskin::train
