// A run's checkpoint: one safetensors file with every module's parameters and buffers ("module.<name>.<param>"),
// every optimizer's state ("optim.<name>.<group>.<index>.exp_avg" / "exp_avg_sq" / "step"), the random generators'
// states ("rng.cpu", "rng.cuda.<i>") and, in the metadata, the step, the task, the configuration, the data cursor
// and the world size. Written atomically; loading checks that it belongs to this task and configuration.
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "training/data.h"
#include "training/optimizer.h"

namespace bareskin::train {

// The checkpoint file of a run folder.
std::string checkpoint_path(const std::string& run_dir);

struct Checkpoint {
  int64_t step = 0;
  std::string task;
  nlohmann::json config;
  data::Cursor cursor;
  int world = 1;
  nlohmann::json trainer = nlohmann::json::object();  // the Trainer's own running state (unlogged loss sums)
};

void save_checkpoint(const std::string& path, const Checkpoint& checkpoint,
                     const std::map<std::string, std::shared_ptr<torch::nn::Module>>& modules,
                     const std::vector<OptimizerSpec>& specs,
                     const std::vector<std::unique_ptr<torch::optim::Optimizer>>& optimizers);

// Restores modules, optimizers and generators. InvalidInput naming the file when it belongs to another task, a
// configuration that differs outside `resumable_keys` (the first differing key is named), another world size, or
// another net (a missing, extra or differently shaped tensor). `upgrade`, when given, first brings the stored
// configuration to this version's keys (TrainerOptions::upgrade_config).
Checkpoint load_checkpoint(const std::string& path, const std::string& task, const nlohmann::json& config,
                           const std::vector<std::string>& resumable_keys,
                           const std::map<std::string, std::shared_ptr<torch::nn::Module>>& modules,
                           const std::vector<OptimizerSpec>& specs,
                           std::vector<std::unique_ptr<torch::optim::Optimizer>>& optimizers, int world,
                           const std::function<void(nlohmann::json&)>& upgrade = {});

int64_t read_checkpoint_step(const std::string& path);

// Only the module weights (for inference and export): "module.<name>.*" into `module`.
void load_module_weights(const std::string& path, const std::string& name, torch::nn::Module& module);

// The checkpoint file of `run`: for a run folder its last stage's (stage2/, else stage1/: a BareSkinNet run keeps
// its stages there), else its own (checkpoint_path, whether it exists or not); any other path as given.
std::string run_checkpoint(const std::string& run);

// A run's module as a plain state dict (the reference implementation's parameter names, as the zoo registers
// them), for Python users: the checkpoint's "module.<name>.*" tensors without the prefix, with the run's config as
// metadata. InvalidInput naming the modules the checkpoint holds when `name` is not one of them.
void export_module(const std::string& checkpoint, const std::string& name, const std::string& output);

}  // namespace bareskin::train
