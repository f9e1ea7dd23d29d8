#include "training/trainer.h"

#include <ATen/autocast_mode.h>

#include <csignal>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/log.h"
#include "core/progress.h"
#include "core/safetensors.h"
#include "training/checkpoint.h"
#include "training/ranks.h"
#include "training/run_flags.h"
#include "training/run_log.h"

namespace bareskin::train {
namespace fs = std::filesystem;

namespace {

volatile std::sig_atomic_t g_stop_signal = 0;
void on_signal(int signal) { g_stop_signal = signal; }

// Installs SIGINT/SIGTERM handlers for the run and restores the previous ones after it.
class SignalScope {
 public:
  SignalScope() {
    g_stop_signal = 0;
    old_int_ = std::signal(SIGINT, on_signal);
    old_term_ = std::signal(SIGTERM, on_signal);
  }
  ~SignalScope() {
    std::signal(SIGINT, old_int_);
    std::signal(SIGTERM, old_term_);
  }

 private:
  void (*old_int_)(int);
  void (*old_term_)(int);
};

}  // namespace

void seed_everything(uint64_t seed) { torch::manual_seed(seed); }

struct Trainer::State {
  TrainerOptions options;
  Task& task;
  data::DataSource& train;
  data::DataSource* validation;
  dist::Group* group;
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules;
  std::vector<OptimizerSpec> specs;
  std::vector<std::unique_ptr<torch::optim::Optimizer>> optimizers;
  int64_t step = 0;
  bool rank0 = true;
  std::unique_ptr<RunLog> log;
  data::Batch sample_batch;  // the sample grids show the same examples at every step
  std::map<std::string, double> interval;  // loss sums since the last log line
  int64_t interval_steps = 0;

  State(TrainerOptions o, Task& t, data::DataSource& tr, data::DataSource* v, dist::Group* g)
      : options(std::move(o)), task(t), train(tr), validation(v), group(g) {
    // A process started as one of several ranks (torchrun, srun) joins their group here unless it was given one.
    if (!group) group = dist::world_group(options.device);
    rank0 = !group || group->rank() == 0;
    modules = task.modules();
    for (auto& [name, module] : modules) module->to(options.device);
    specs = task.optimizers();
    for (const auto& spec : specs) optimizers.push_back(make_optimizer(spec));
  }

  static std::unique_ptr<torch::optim::Optimizer> make_optimizer(const OptimizerSpec& spec) {
    if (spec.kind != "adam" && spec.kind != "adamw")
      throw InvalidInput("optimizer '" + spec.kind + "'", "is not supported", "use adam or adamw");
    std::vector<torch::optim::OptimizerParamGroup> groups;
    for (const auto& g : spec.groups) {
      if (spec.kind == "adam") {
        auto o = std::make_unique<torch::optim::AdamOptions>(g.lr);
        o->betas({spec.beta1, spec.beta2}).eps(spec.eps).weight_decay(spec.weight_decay);
        groups.emplace_back(g.params, std::move(o));
      } else {
        auto o = std::make_unique<torch::optim::AdamWOptions>(g.lr);
        o->betas({spec.beta1, spec.beta2}).eps(spec.eps).weight_decay(spec.weight_decay);
        groups.emplace_back(g.params, std::move(o));
      }
    }
    if (spec.kind == "adam") return std::make_unique<torch::optim::Adam>(groups);
    return std::make_unique<torch::optim::AdamW>(groups);
  }

  void set_learning_rates() {
    for (size_t o = 0; o < specs.size(); ++o) {
      const double f = specs[o].schedule.factor(step, options.steps);
      auto& groups = optimizers[o]->param_groups();
      for (size_t g = 0; g < groups.size(); ++g) groups[g].options().set_lr(specs[o].groups[g].lr * f);
    }
  }

  std::vector<torch::Tensor> params_of(size_t o) const {
    std::vector<torch::Tensor> params;
    for (const auto& g : specs[o].groups) params.insert(params.end(), g.params.begin(), g.params.end());
    return params;
  }

  // One phase: losses -> (ranks agree on their values) -> NaN stop -> backward -> gradient average -> clip -> step.
  std::map<std::string, double> phase(size_t o, const data::Batch& batch) {
    auto& optimizer = *optimizers[o];
    optimizer.zero_grad();
    Losses losses;
    {
      const bool autocast = options.device.is_cuda() && options.bf16;
      at::autocast::set_enabled(autocast);
      if (autocast) at::autocast::set_autocast_gpu_dtype(at::kBFloat16);
      losses = task.loss(o, batch);
      at::autocast::set_enabled(false);
      if (autocast) at::autocast::clear_cache();
    }
    BS_CHECK(!losses.empty(), "a phase must return at least one loss");
    std::vector<torch::Tensor> parts;
    for (auto& [name, value] : losses) parts.push_back(value.detach().to(torch::kFloat64).reshape({1}));
    auto values = torch::cat(parts).cpu();
    if (group) {
      std::vector<torch::Tensor> v{values.clone()};
      group->average(v);
      values = v[0];
    }
    std::map<std::string, double> logged;
    size_t i = 0;
    for (auto& [name, value] : losses) {
      const double x = values[int64_t(i++)].item<double>();
      if (!std::isfinite(x)) diverged(specs[o].name + "/" + name, x);
      logged[specs[o].name + "/" + name] = x;
    }
    torch::Tensor total = losses.begin()->second.to(torch::kFloat32);
    for (auto it = std::next(losses.begin()); it != losses.end(); ++it) total = total + it->second.to(torch::kFloat32);
    total.backward();
    auto params = params_of(o);
    if (group) {
      std::vector<torch::Tensor> grads;
      for (auto& p : params) {
        if (!p.grad().defined()) p.mutable_grad() = torch::zeros_like(p);
        grads.push_back(p.mutable_grad());
      }
      group->average(grads);
    }
    if (options.clip_grad_norm > 0) {  // the norm before clipping is logged: how often and how hard the clip bites
      const double norm = torch::nn::utils::clip_grad_norm_(params, options.clip_grad_norm);
      if (!std::isfinite(norm)) diverged(specs[o].name + "/grad_norm", norm);
      logged[specs[o].name + "/grad_norm"] = norm;
    }
    optimizer.step();
    return logged;
  }

  // What a stopped run leaves: "the last good checkpoint is <file> (step N)" or "no checkpoint was written yet".
  std::string kept_checkpoint() const {
    const std::string checkpoint = checkpoint_path(options.run_dir);
    return fs::exists(checkpoint) ? "the last good checkpoint is " + checkpoint + " (step " +
                                        std::to_string(read_checkpoint_step(checkpoint)) + ")"
                                  : "no checkpoint was written yet";
  }

  [[noreturn]] void diverged(const std::string& name, double value) const {
    const std::string kept = kept_checkpoint();
    throw InvalidInput("step " + std::to_string(step + 1), "loss '" + name + "' is " + (std::isnan(value) ? "NaN" : "infinite") +
                                                               "; training stopped and " + kept,
                       "lower the learning rate or check the data, then --resume");
  }

  void set_train(bool train_mode) {
    for (auto& [name, module] : modules) module->train(train_mode);
  }

  std::map<std::string, double> evaluate() {
    std::map<std::string, double> sums;
    set_train(false);
    {
      torch::NoGradGuard no_grad;
      validation->seek({0, 0});
      for (int64_t b = 0; b < options.eval_batches; ++b)
        for (auto& [name, value] : task.evaluate(validation->next())) sums[name] += value / double(options.eval_batches);
    }
    set_train(true);
    return sums;
  }

  Checkpoint snapshot() const {
    Checkpoint c;
    c.step = step;
    c.task = task.name();
    c.config = options.config;
    c.cursor = train.cursor();
    c.world = group ? group->world() : 1;
    c.trainer = {{"interval", interval}, {"interval_steps", interval_steps}};
    return c;
  }
};

void check_intervals(int64_t steps, int64_t log_every, int64_t checkpoint_every, int64_t eval_every, int64_t sample_every) {
  if (steps < 1) throw InvalidInput("--steps", "must be at least 1", "e.g. --steps 1000");
  if (log_every < 1) throw InvalidInput("--log-every", "must be at least 1", "e.g. --log-every 10");
  if (checkpoint_every < 0 || eval_every < 0 || sample_every < 0)
    throw InvalidInput("--checkpoint-every/--eval-every/--sample-every", "must not be negative", "0 is never");
}

void RunFlags::check() const {
  check_intervals(steps, log_every, checkpoint_every, eval_every, sample_every);
  if (batch < 1) throw InvalidInput("--batch", "must be at least 1", "give a positive batch size");
}

void TrainerOptions::check() const {
  if (run_dir.empty()) throw InvalidInput("-o", "names no run folder", "give the run's output folder");
  check_intervals(steps, log_every, checkpoint_every, eval_every, sample_every);
  if (eval_batches < 1) throw InvalidInput("eval_batches", "must be at least 1", "e.g. 8 (default)");
  if (!(clip_grad_norm >= 0 && std::isfinite(clip_grad_norm)))
    throw InvalidInput("clip_grad_norm", "must be finite and >= 0", "0 is off");
}

Trainer::Trainer(TrainerOptions options, Task& task, data::DataSource& train, data::DataSource* validation,
                 dist::Group* group)
    : state_((options.check(), std::make_unique<State>(std::move(options), task, train, validation, group))) {}

Trainer::~Trainer() = default;

TrainResult Trainer::run() {
  State& s = *state_;
  const TrainerOptions& o = s.options;
  SignalScope signals;
  // Pin LibTorch's intra-op thread count before the first step. Left to its lazy default, the count OpenMP uses can
  // change after the first parallel ops of a process, and reductions split over another number of threads round
  // differently: a resumed (fresh) process would then not repeat an uninterrupted run bit for bit.
  torch::set_num_threads(torch::get_num_threads());
  const std::string checkpoint = checkpoint_path(o.run_dir);
  if (s.rank0) make_directories(o.run_dir);
  if (o.resume) {
    if (!fs::exists(checkpoint))
      throw InvalidInput(o.run_dir, "has no checkpoint.safetensors to resume from", "start without --resume");
    Checkpoint c = load_checkpoint(checkpoint, s.task.name(), o.config, o.resumable_keys, s.modules, s.specs,
                                   s.optimizers, s.group ? s.group->world() : 1, o.upgrade_config);
    s.step = c.step;
    s.train.seek(c.cursor);
    s.interval = c.trainer.value("interval", std::map<std::string, double>{});
    s.interval_steps = c.trainer.value("interval_steps", int64_t(0));
  } else if (s.rank0 && fs::exists(checkpoint)) {
    throw InvalidInput(o.run_dir, "already holds a run (checkpoint.safetensors)",
                       "pass --resume to continue it, or choose a new run folder");
  }
  if (s.group) {
    s.group->check_same(s.step, "the resumed step");
    std::vector<torch::Tensor> state;
    for (auto& [name, module] : s.modules) {
      for (auto& p : module->parameters()) state.push_back(p);
      for (auto& b : module->buffers()) state.push_back(b);
    }
    s.group->broadcast(state);
  }
  if (s.rank0) {
    write_file_atomic(o.run_dir + "/config.json", o.config.dump(2) + "\n");
    s.log = std::make_unique<RunLog>(o.run_dir, s.step);
  }
  s.set_train(true);
  ProgressBar bar("train " + s.task.name(), o.progress && s.rank0);
  auto& interval = s.interval;
  auto& interval_steps = s.interval_steps;
  TrainResult result;
  auto save = [&] {
    if (!s.rank0) return;
    try {
      save_checkpoint(checkpoint, s.snapshot(), s.modules, s.specs, s.optimizers);
    } catch (const IoError& e) {  // a full disk: the file is written aside and renamed, so the last one is intact
      throw IoError(std::string(e.what()) + " (step " + std::to_string(s.step) + "; training stopped and " +
                    s.kept_checkpoint() + ": free space, then --resume)");
    }
  };
  while (s.step < o.steps) {
    data::Batch batch;
    try {
      batch = s.train.next();
    } catch (const InvalidInput& e) {  // e.g. a shard damaged while the run reads it: named with its member
      throw InvalidInput(std::string(e.what()) + " (before step " + std::to_string(s.step + 1) +
                         "; training stopped and " + s.kept_checkpoint() + ": repair the data, then --resume)");
    }
    for (auto& [name, t] : batch.tensors) t = t.to(o.device);
    if (s.rank0 && o.sample_every > 0 && s.sample_batch.keys.empty()) {
      // The validation split's first batch where there is one (the same at every start), else this run's first.
      if (s.validation) {
        s.validation->seek({0, 0});
        s.sample_batch = s.validation->next();
        for (auto& [name, t] : s.sample_batch.tensors) t = t.to(o.device);
      } else {
        s.sample_batch = batch;
      }
    }
    s.set_learning_rates();
    for (size_t p = 0; p < s.optimizers.size(); ++p)
      for (auto& [name, value] : s.phase(p, batch)) interval[name] += value;
    ++s.step;
    ++interval_steps;
    if (s.rank0 && (s.step % o.log_every == 0 || s.step == o.steps)) {
      for (auto& [name, value] : interval) value /= double(interval_steps);
      std::map<std::string, double> rates;
      for (size_t i = 0; i < s.specs.size(); ++i)
        for (size_t g = 0; g < s.specs[i].groups.size(); ++g)
          rates[s.specs[i].name + "/" + s.specs[i].groups[g].name] =
              s.optimizers[i]->param_groups()[g].options().get_lr();
      s.log->losses(s.step, interval, rates);
      result.last_losses = interval;
      interval.clear();
      interval_steps = 0;
    }
    if (s.validation && o.eval_every > 0 && (s.step % o.eval_every == 0 || s.step == o.steps)) {
      auto metrics = s.evaluate();  // every rank evaluates (cheap, keeps modes in step); rank 0 logs
      if (s.rank0) s.log->evaluation(s.step, metrics);
      result.last_eval = metrics;
    }
    if (s.rank0 && o.sample_every > 0 && (s.step % o.sample_every == 0 || s.step == o.steps)) {
      s.set_train(false);
      torch::NoGradGuard no_grad;
      s.log->samples(s.step, s.task.samples(s.sample_batch));
      s.set_train(true);
    }
    if (o.checkpoint_every > 0 && (s.step % o.checkpoint_every == 0 || s.step == o.steps)) save();
    if (g_stop_signal) {
      save();
      bar.finish();
      spdlog::info("{}: stopped by signal {} at step {}; checkpoint written, continue with --resume", o.run_dir,
                int(g_stop_signal), s.step);
      result.steps = s.step;
      return result;
    }
    bar.update(s.step, o.steps, fmt::format("step {}", s.step));
  }
  bar.finish();
  result.steps = s.step;
  return result;
}

}  // namespace bareskin::train
