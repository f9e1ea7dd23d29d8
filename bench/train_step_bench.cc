// The C++ half of the training-step comparison with PyTorch eager (bench/step_vs_pytorch.sh runs both halves; the
// Python half, bench/step_vs_pytorch.py, builds the same nets in torch.nn). One net and size per run, trained by the
// toolkit's own train::Trainer on one batch held in memory (no loading, no logging, checkpoints or samples):
//   F  recon's ReconNet (a ResNet-18 of --width with zero-initialised heads for --coeffs and γ) on [B, 3, S, S],
//      the mean squared error to fixed random coefficients, Adam (recon's rate 1e-4).
//   G  BareSkinNet stage 1 (bsn::BareSkinTask itself): the U-Net of ngf --width (num_downs = max(5, log2 S)),
//      residual, and the PatchGAN of --ndf / --n-layers; D's step (vanilla GAN), then G's (L1 ×100 + GAN); Adam
//      2e-4, β 0.5 / 0.999. LPIPS is off (w3 0).
// A step's time is the time between the starts of two consecutive steps (the Task's first phase), so it holds
// everything the Trainer does per step; wall time ("ms") and the process's CPU time ("cpu_ms", all threads: what a
// loaded machine does not inflate). Prints one JSON line: the parameters per module, the step times and the median
// of --steps steps after --warmup.
//   train_step_bench --net F|G --width W --size S [--batch 8] [--steps 20] [--warmup 5] [--threads 2]
//                    [--ndf 16] [--n-layers 2] [--coeffs 80,64,80]
#include <CLI/CLI.hpp>
#include <malloc.h>
#include <torch/torch.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "bareskinnet/bareskinnet.h"
#include "bench/bench_util.h"
#include "recon/recon.h"
#include "training/nets/zoo.h"
#include "training/trainer.h"

// One namespace per program: bench/torch_bench.cc runs this main under the name `train_step_bench` (one binary, one unity
// translation unit for every Torch bench).
namespace bareskin_bench_train_step {

using namespace bareskin;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

struct Args {
  std::string net = "F";
  int width = 8, size = 64, batch = 8, steps = 20, warmup = 5, threads = 2, ndf = 16, n_layers = 2;
  std::vector<int64_t> coeffs = {80, 64, 80};
};

// The same batch at every step: the step is timed, not the loader.
class FixedBatch : public data::DataSource {
 public:
  explicit FixedBatch(data::Batch batch) : batch_(std::move(batch)) {}
  data::Batch next() override {
    ++index_;
    return batch_;
  }
  data::Cursor cursor() const override { return {0, index_}; }
  void seek(const data::Cursor& c) override { index_ = c.index; }
  int64_t epoch_size() const override { return batch_.size(); }

 private:
  data::Batch batch_;
  int64_t index_ = 0;
};

data::Batch random_batch(int64_t n, const std::map<std::string, torch::Tensor>& tensors) {
  data::Batch b;
  for (int64_t i = 0; i < n; ++i) b.keys.push_back(std::to_string(i));
  b.tensors = tensors;
  b.meta.assign(size_t(n), nlohmann::json::object());
  return b;
}

double cpu_ms_now() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return double(t.tv_sec) * 1e3 + double(t.tv_nsec) * 1e-6;
}

// Forwards to a task and notes when each step starts (its first phase): wall clock and process CPU time.
class ClockedTask : public train::Task {
 public:
  explicit ClockedTask(train::Task& inner) : inner_(inner) {}
  std::string name() const override { return inner_.name(); }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override { return inner_.modules(); }
  std::vector<train::OptimizerSpec> optimizers() override { return inner_.optimizers(); }
  train::Losses loss(size_t phase, const data::Batch& batch) override {
    if (phase == 0) {
      starts_.push_back(Clock::now());
      cpu_starts_.push_back(cpu_ms_now());
    }
    return inner_.loss(phase, batch);
  }
  std::vector<double> step_ms() const {
    std::vector<double> ms;
    for (size_t i = 1; i < starts_.size(); ++i)
      ms.push_back(std::chrono::duration<double, std::milli>(starts_[i] - starts_[i - 1]).count());
    return ms;
  }
  std::vector<double> step_cpu_ms() const {
    std::vector<double> ms;
    for (size_t i = 1; i < cpu_starts_.size(); ++i) ms.push_back(cpu_starts_[i] - cpu_starts_[i - 1]);
    return ms;
  }

 private:
  train::Task& inner_;
  std::vector<Clock::time_point> starts_;
  std::vector<double> cpu_starts_;
};

// F with a step-bench loss: MSE of its coefficients to fixed targets.
class ReconStepTask : public train::Task {
 public:
  ReconStepTask(const Args& a) {
    recon::ReconNetOptions o;
    o.arch = "resnet18";
    o.width = a.width;
    recon::CoefficientLayout layout{a.coeffs.at(0), a.coeffs.at(1), a.coeffs.at(2), true};
    net_ = recon::ReconNet(o, layout);
  }
  std::string name() const override { return "recon_step"; }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override { return {{"F", net_.ptr()}}; }
  std::vector<train::OptimizerSpec> optimizers() override {
    train::OptimizerSpec s;
    s.name = "F";
    s.groups = {{"net", net_->parameters(), recon::ReconTaskOptions{}.lr}};
    return {s};
  }
  train::Losses loss(size_t, const data::Batch& b) override {
    return {{"mse", torch::mse_loss(net_->forward(b.at("image")), b.at("target"))}};
  }
  int64_t outputs() const { return net_->layout().size(); }

 private:
  recon::ReconNet net_{nullptr};
};

std::unique_ptr<bsn::BareSkinTask> bareskin_stage1(const Args& a) {
  bsn::Options o;
  o.stage = 1;
  o.size = a.size;
  o.g = {{"ngf", a.width}};
  o.d = {{"ndf", a.ndf}, {"n_layers", a.n_layers}};
  o.w3 = 0;
  o.lr_g = o.lr_d = 2e-4;
  return std::make_unique<bsn::BareSkinTask>(o);
}

struct StepTimes {
  std::vector<double> wall, cpu;
};

// The Trainer on `task` for warmup + steps + 1 steps; the step times after the warm-up.
StepTimes train_steps(train::Task& task, data::DataSource& source, const Args& a) {
  ClockedTask clocked(task);
  train::TrainerOptions o;
  o.run_dir = (fs::temp_directory_path() / ("bareskin_step_bench_" + std::to_string(::getpid()))).string();
  o.steps = a.warmup + a.steps + 1;
  o.log_every = o.steps;
  o.checkpoint_every = o.eval_every = o.sample_every = 0;
  o.progress = false;
  train::Trainer(o, clocked, source, nullptr).run();
  fs::remove_all(o.run_dir);
  StepTimes t{clocked.step_ms(), clocked.step_cpu_ms()};
  t.wall.erase(t.wall.begin(), t.wall.begin() + a.warmup);
  t.cpu.erase(t.cpu.begin(), t.cpu.begin() + a.warmup);
  return t;
}

nlohmann::json run(const Args& a) {
  torch::manual_seed(1);
  std::map<std::string, int64_t> params;
  StepTimes ms;
  const int64_t b = a.batch, s = a.size;
  if (a.net == "F") {
    ReconStepTask task(a);
    FixedBatch source(random_batch(b, {{"image", torch::rand({b, 3, s, s})}, {"target", torch::randn({b, task.outputs()})}}));
    for (auto& [name, m] : task.modules()) params[name] = nets::parameter_count(*m);
    ms = train_steps(task, source, a);
  } else {
    auto task = bareskin_stage1(a);
    FixedBatch source(random_batch(b, {{"makeup", torch::rand({b, 3, s, s})}, {"before", torch::rand({b, 3, s, s})}}));
    for (auto& [name, m] : task->modules()) params[name] = nets::parameter_count(*m);
    ms = train_steps(*task, source, a);
  }
  return {{"side", "c++"},        {"net", a.net},         {"width", a.width},
          {"size", a.size},       {"batch", a.batch},     {"threads", torch::get_num_threads()},
          {"params", params},     {"ms", ms.wall},        {"median_ms", bench::median(ms.wall)},
          {"cpu_ms", ms.cpu},     {"median_cpu_ms", bench::median(ms.cpu)},
          {"omp_wait_policy", std::getenv("OMP_WAIT_POLICY") ? std::getenv("OMP_WAIT_POLICY") : ""}};
}

}  // namespace

int main(int argc, char** argv) {
  mallopt(M_MMAP_MAX, 0);  // as the CLI (apps/cli.cc): page faults are expensive on these VMs
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  Args a;
  CLI::App app("Training-step time of F or G through the Trainer (one JSON line)");
  app.add_option("--net", a.net, "F (train recon) or G (train bareskin, stage 1)")->check(CLI::IsMember({"F", "G"}));
  app.add_option("--width", a.width, "F: the ResNet's width; G: the U-Net's ngf")->check(CLI::PositiveNumber);
  app.add_option("--size", a.size, "Image side")->check(CLI::PositiveNumber);
  app.add_option("--batch", a.batch)->check(CLI::PositiveNumber);
  app.add_option("--steps", a.steps, "Timed steps")->check(CLI::PositiveNumber);
  app.add_option("--warmup", a.warmup, "Untimed steps first")->check(CLI::NonNegativeNumber);
  app.add_option("--threads", a.threads)->check(CLI::PositiveNumber);
  app.add_option("--ndf", a.ndf, "G's PatchGAN width")->check(CLI::PositiveNumber);
  app.add_option("--n-layers", a.n_layers, "G's PatchGAN layers")->check(CLI::PositiveNumber);
  app.add_option("--coeffs", a.coeffs, "F's K_id,K_exp,K_app (γ's 27 and the pose's 6 come on top)")
      ->delimiter(',')
      ->expected(3);
  CLI11_PARSE(app, argc, argv);
  try {
    torch::set_num_threads(a.threads);
    std::printf("%s\n", run(a).dump().c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "train_step_bench: %s\n", e.what());
    return 3;
  }
  return 0;
}

}  // namespace bareskin_bench_train_step
