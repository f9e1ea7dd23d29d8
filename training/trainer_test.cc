#include "training/trainer.h"

#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>

#include <csignal>
#include <filesystem>

#include "core/error.h"
#include "core/files.h"
#include "core/test_options.h"
#include "core/test_util.h"
#include "training/checkpoint.h"
#include "training/tensor_io.h"

extern char** environ;

namespace bareskin::train {
namespace {
namespace fs = std::filesystem;

// Example j of an endless synthetic stream: a 2x8x8 input and its target (a fixed blur of the input).
data::Example synthetic_example(int64_t j) {
  auto gen = at::detail::createCPUGenerator(uint64_t(j) + 1000);
  data::Example e;
  e.key = std::to_string(j);
  auto x = torch::randn({2, 8, 8}, gen);
  e.tensors["input"] = x;
  e.tensors["target"] = 0.5 * x + 0.25 * torch::roll(x, {1}, {2}) + 0.1;
  return e;
}

// Batches of a global stream split over ranks: step s of rank r holds examples (s*world + r)*batch ... +batch-1,
// so one process at batch*world sees exactly the union of what the ranks see.
class StreamSource : public data::DataSource {
 public:
  StreamSource(int64_t batch, int rank, int world) : batch_(batch), rank_(rank), world_(world) {}
  data::Batch next() override {
    std::vector<data::Example> examples;
    for (int64_t i = 0; i < batch_; ++i) examples.push_back(synthetic_example((step_ * world_ + rank_) * batch_ + i));
    ++step_;
    return data::collate(examples);
  }
  data::Cursor cursor() const override { return {0, step_}; }
  void seek(const data::Cursor& c) override { step_ = c.index; }
  int64_t epoch_size() const override { return 1 << 30; }

 private:
  int64_t batch_, step_ = 0;
  int rank_, world_;
};

// Two small nets trained in two phases (as a GAN's G and D are): A maps input to target; B learns A's residual.
// Dropout in A makes the run depend on the generator state, which a resume must restore.
struct TwoNetTask : Task {
  torch::nn::Sequential a{torch::nn::Conv2d(torch::nn::Conv2dOptions(2, 8, 3).padding(1)), torch::nn::ReLU(),
                          torch::nn::Dropout(0.2), torch::nn::Conv2d(torch::nn::Conv2dOptions(8, 2, 3).padding(1))};
  torch::nn::Sequential b{torch::nn::Conv2d(torch::nn::Conv2dOptions(2, 2, 1))};
  int64_t nan_at = -1, nan_grad_at = -1, signal_at = -1, calls = 0;  // nan_grad_at: a finite loss, NaN gradients
  std::string kind = "adam";
  int64_t step_every = 7;  // A's step schedule (0: constant)

  std::string name() const override { return "two-net"; }
  std::map<std::string, std::shared_ptr<torch::nn::Module>> modules() override {
    return {{"A", a.ptr()}, {"B", b.ptr()}};
  }
  std::vector<OptimizerSpec> optimizers() override {
    OptimizerSpec oa{"A", kind, {{"all", a->parameters(), 1e-2}}};
    oa.schedule.kind = "step";
    oa.schedule.step_every = step_every;
    OptimizerSpec ob{"B", kind, {{"all", b->parameters(), 5e-3}}};
    ob.schedule.kind = "linear";
    ob.schedule.decay_start = 5;
    return {oa, ob};
  }
  Losses loss(size_t phase, const data::Batch& batch) override {
    ++calls;
    if (signal_at == calls) std::raise(SIGTERM);
    auto out = a->forward(batch.at("input"));
    if (phase == 0) {
      auto l1 = (out - batch.at("target")).abs().mean();
      if (nan_at == calls) l1 = l1 * std::nan("");
      if (nan_grad_at == calls) l1 = l1 + (out * 0).sum().sqrt();  // 0, whose gradient is inf · 0
      return {{"l1", l1}, {"l2", 0.5 * (out - batch.at("target")).pow(2).mean()}};
    }
    auto residual = (batch.at("target") - out).detach();
    return {{"residual", (b->forward(batch.at("input")) - residual).pow(2).mean()}};
  }
  std::map<std::string, double> evaluate(const data::Batch& batch) override {
    return {{"l1", (a->forward(batch.at("input")) - batch.at("target")).abs().mean().item<double>()}};
  }
  std::vector<std::vector<torch::Tensor>> samples(const data::Batch& batch) override {
    auto out = a->forward(batch.at("input"));
    return {{batch.at("input")[0].slice(0, 0, 1).sigmoid(), out[0].slice(0, 0, 1).sigmoid()}};
  }
};

// Runs one test of this binary in a new process with extra environment variables; returns its pid (-1 on failure).
pid_t spawn_self(const std::string& test, std::vector<std::string> env) {
  for (char** e = environ; *e; ++e) env.push_back(*e);
  std::vector<char*> envp;
  for (auto& s : env) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::string exe = fs::read_symlink("/proc/self/exe").string(), filter = "--gtest_filter=" + test;
  char* argv[] = {exe.data(), filter.data(), nullptr};
  pid_t pid = -1;
  if (posix_spawn(&pid, exe.c_str(), nullptr, nullptr, argv, envp.data()) != 0) return -1;
  return pid;
}

bool exited_cleanly(pid_t pid) {
  int status = 0;
  return pid > 0 && waitpid(pid, &status, 0) == pid && WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

TrainerOptions options(const std::string& dir, int64_t steps) {
  TrainerOptions o;
  o.run_dir = dir;
  o.steps = steps;
  o.log_every = 2;
  o.checkpoint_every = 4;
  o.eval_every = 5;
  o.eval_batches = 2;
  o.sample_every = 5;
  o.progress = false;
  o.config = {{"model", {{"width", 8}}}, {"steps", steps}};
  return o;
}

std::map<std::string, torch::Tensor> weights(TwoNetTask& task) {
  std::map<std::string, torch::Tensor> out;
  for (auto& [name, module] : task.modules())
    for (auto& p : module->named_parameters()) out[name + "." + p.key()] = p.value().detach().clone();
  return out;
}

void expect_identical(const std::map<std::string, torch::Tensor>& a, const std::map<std::string, torch::Tensor>& b) {
  ASSERT_EQ(a.size(), b.size());
  for (const auto& [name, t] : a) EXPECT_TRUE(torch::equal(t, b.at(name))) << name << " differs";
}

TEST(Trainer, LossFallsOnAFixedBatchAndRunFolderIsComplete) {
  const std::string dir = testing::temp_dir() + "/run";
  seed_everything(1);
  TwoNetTask task;
  task.step_every = 0;
  struct Fixed : StreamSource {
    Fixed() : StreamSource(4, 0, 1) {}
    data::Batch next() override {
      seek({0, 0});
      return StreamSource::next();
    }
  } fixed;
  auto o = options(dir, 40);
  o.log_every = 5;  // last_losses: the mean of the last 5 steps
  Trainer first(options(dir + "_first", 1), task, fixed, nullptr);
  const double start = first.run().last_losses.at("A/l1");
  StreamSource validation(4, 0, 1);
  Trainer trainer(o, task, fixed, &validation);
  const auto result = trainer.run();
  EXPECT_LT(result.last_losses.at("A/l1"), 0.5 * start) << "start " << start;
  for (const char* file : {"config.json", "metrics.csv", "eval.csv", "losses.svg", "lr.svg", "eval.svg",
                           "checkpoint.safetensors", "samples/step_0000040.png"})
    EXPECT_TRUE(fs::exists(dir + "/" + file)) << file;
  EXPECT_EQ(read_checkpoint_step(checkpoint_path(dir)), 40);
}

// N steps, stop (SIGTERM: the checkpoint is written at once), resume N more == 2N uninterrupted: the same bytes in
// every parameter, for both optimizers.
TEST(Trainer, ResumeIsBitIdentical) {
  for (const std::string kind : {"adam", "adamw"}) {
    const std::string base = testing::temp_dir();
    seed_everything(7);
    TwoNetTask straight;
    straight.kind = kind;
    StreamSource s1(3, 0, 1);
    StreamSource v1(3, 0, 1);
    Trainer(options(base + "/straight", 18), straight, s1, &v1).run();

    seed_everything(7);
    TwoNetTask interrupted;
    interrupted.kind = kind;
    interrupted.signal_at = 2 * 8 + 1;  // during step 9's first phase: step 9 completes, then the run stops
    StreamSource s2(3, 0, 1);
    StreamSource v2(3, 0, 1);
    EXPECT_EQ(Trainer(options(base + "/resumed", 18), interrupted, s2, &v2).run().steps, 9);
    EXPECT_EQ(read_checkpoint_step(checkpoint_path(base + "/resumed")), 9);

    seed_everything(12345);  // another start: everything must come from the checkpoint
    TwoNetTask resumed;
    resumed.kind = kind;
    StreamSource s3(3, 0, 1);
    auto o = options(base + "/resumed", 18);
    o.resume = true;
    StreamSource v3(3, 0, 1);
    Trainer(o, resumed, s3, &v3).run();
    expect_identical(weights(straight), weights(resumed));
    // The logs hold each step once, and the same values as the straight run's.
    EXPECT_EQ(read_file(base + "/resumed/metrics.csv"), read_file(base + "/straight/metrics.csv"));
  }
}

// The resumed half in a new process, as after a real kill: it must repeat the uninterrupted run to the byte too.
TEST(Trainer, ResumeWorker) {
  const char* dir = std::getenv("BARESKIN_RESUME_TEST_DIR");
  if (!dir) GTEST_SKIP() << "run by Trainer.ResumeInAFreshProcessIsBitIdentical";
  TwoNetTask resumed;
  StreamSource source(3, 0, 1), validation(3, 0, 1);
  auto o = options(std::string(dir) + "/resumed", 18);
  o.resume = true;
  Trainer(o, resumed, source, &validation).run();
  save_tensors(std::string(dir) + "/weights.safetensors", weights(resumed));
}

TEST(Trainer, ResumeInAFreshProcessIsBitIdentical) {
  const std::string base = testing::temp_dir();
  seed_everything(7);
  TwoNetTask straight;
  StreamSource s1(3, 0, 1), v1(3, 0, 1);
  Trainer(options(base + "/straight", 18), straight, s1, &v1).run();
  seed_everything(7);
  TwoNetTask interrupted;
  interrupted.signal_at = 2 * 8 + 1;
  StreamSource s2(3, 0, 1), v2(3, 0, 1);
  ASSERT_EQ(Trainer(options(base + "/resumed", 18), interrupted, s2, &v2).run().steps, 9);
  ASSERT_TRUE(exited_cleanly(spawn_self("Trainer.ResumeWorker", {"BARESKIN_RESUME_TEST_DIR=" + base})));
  expect_identical(weights(straight), load_tensors(base + "/weights.safetensors"));
  EXPECT_EQ(read_file(base + "/resumed/metrics.csv"), read_file(base + "/straight/metrics.csv"));
}

// kill -9 between checkpoints: the run resumes from the last periodic checkpoint and redoes the lost steps.
TEST(Trainer, ResumeFromAPeriodicCheckpoint) {
  const std::string base = testing::temp_dir();
  seed_everything(3);
  TwoNetTask straight;
  StreamSource s1(2, 0, 1);
  Trainer(options(base + "/a", 12), straight, s1, nullptr).run();

  seed_everything(3);
  TwoNetTask killed;
  StreamSource s2(2, 0, 1);
  Trainer(options(base + "/b", 12), killed, s2, nullptr).run();
  // Put back the checkpoint of step 8 as if the process had died at step 10.
  seed_everything(3);
  TwoNetTask to8;
  to8.signal_at = 2 * 7 + 1;
  StreamSource s3(2, 0, 1);
  Trainer(options(base + "/c", 12), to8, s3, nullptr).run();
  fs::copy_file(checkpoint_path(base + "/c"), checkpoint_path(base + "/b"), fs::copy_options::overwrite_existing);
  TwoNetTask resumed;
  StreamSource s4(2, 0, 1);
  auto o = options(base + "/b", 12);
  o.resume = true;
  Trainer(o, resumed, s4, nullptr).run();
  expect_identical(weights(straight), weights(resumed));
  EXPECT_EQ(read_file(base + "/b/metrics.csv"), read_file(base + "/a/metrics.csv"));
}

TEST(Trainer, NanStopsWithTheStepAndKeepsTheLastGoodCheckpoint) {
  const std::string dir = testing::temp_dir() + "/nan";
  TwoNetTask task;
  task.nan_at = 2 * 5 + 1;  // step 6, phase A
  StreamSource source(2, 0, 1);
  try {
    Trainer(options(dir, 20), task, source, nullptr).run();
    FAIL() << "training continued on NaN";
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("step 6"), std::string::npos) << what;
    EXPECT_NE(what.find("A/l1"), std::string::npos) << what;
    EXPECT_NE(what.find("(step 4)"), std::string::npos) << what;
  }
  EXPECT_EQ(read_checkpoint_step(checkpoint_path(dir)), 4);
}

TEST(Trainer, RefusesAnotherConfigAnotherNetAndAnExistingRun) {
  const std::string dir = testing::temp_dir() + "/refuse";
  TwoNetTask task;
  StreamSource source(2, 0, 1);
  Trainer(options(dir, 4), task, source, nullptr).run();
  const std::string before = read_file(checkpoint_path(dir));
  EXPECT_THROW(Trainer(options(dir, 8), task, source, nullptr).run(), InvalidInput);  // no --resume
  auto other = options(dir, 8);
  other.resume = true;
  other.config["model"]["width"] = 16;
  try {
    Trainer(other, task, source, nullptr).run();
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("model.width"), std::string::npos) << e.what();
  }
  struct Wider : TwoNetTask {
    Wider() { b = torch::nn::Sequential(torch::nn::Conv2d(torch::nn::Conv2dOptions(2, 2, 3))); }
  } wider;
  auto same = options(dir, 8);
  same.resume = true;
  EXPECT_THROW(Trainer(same, wider, source, nullptr).run(), InvalidInput);
  // Another world size: the data order would differ, so the checkpoint is refused.
  std::vector<std::unique_ptr<torch::optim::Optimizer>> none;
  try {
    load_checkpoint(checkpoint_path(dir), "two-net", options(dir, 4).config, {}, task.modules(), {}, none, 2);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("1 rank(s), this run has 2"), std::string::npos) << e.what();
  }
  EXPECT_EQ(read_file(checkpoint_path(dir)), before);  // nothing overwritten
}

// A run whose stored configuration an earlier version wrote (an option renamed since) resumes once upgrade_config
// brings it to today's keys; without it, the renamed key is refused as another configuration.
TEST(Trainer, ResumesAConfigurationUpgradedToTodaysKeys) {
  const std::string dir = testing::temp_dir() + "/upgrade";
  TwoNetTask task;
  StreamSource source(2, 0, 1);
  Trainer(options(dir, 4), task, source, nullptr).run();
  auto renamed = options(dir, 8);
  renamed.resume = true;
  renamed.config["model"] = {{"channels", 8}};
  EXPECT_THROW(Trainer(renamed, task, source, nullptr).run(), InvalidInput);
  renamed.upgrade_config = [](nlohmann::json& stored) {
    stored["model"] = {{"channels", stored["model"]["width"]}};
  };
  EXPECT_EQ(Trainer(renamed, task, source, nullptr).run().steps, 8);
  // Another task's checkpoint is refused by its task's name before the hook reads its configuration as this task's.
  std::vector<std::unique_ptr<torch::optim::Optimizer>> none;
  bool hook_ran = false;
  try {
    load_checkpoint(checkpoint_path(dir), "texture", renamed.config, {}, task.modules(), {}, none, 1,
                    [&](nlohmann::json&) { hook_ran = true; });
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("is a checkpoint of 'two-net', not 'texture'"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(hook_ran);
}

// Clipping: on, each optimizer's norm before it is logged; a bound the gradients never reach changes nothing, bit for
// bit; a bound they always exceed changes the run.
TEST(Trainer, ClipLogsTheNormBeforeItAndBoundsTheGradients) {
  auto run = [](const std::string& name, double clip) {
    seed_everything(3);
    TwoNetTask task;
    StreamSource source(2, 0, 1);
    auto o = options(testing::temp_dir() + "/clip_" + name, 6);
    o.log_every = 1;
    o.clip_grad_norm = clip;
    const auto result = Trainer(o, task, source, nullptr).run();
    return std::make_pair(result.last_losses, weights(task));
  };
  const auto [off, off_weights] = run("off", 0);
  EXPECT_FALSE(off.count("A/grad_norm"));
  const auto [loose, loose_weights] = run("loose", 1e9);
  ASSERT_TRUE(loose.count("A/grad_norm") && loose.count("B/grad_norm"));
  EXPECT_GT(loose.at("A/grad_norm"), 1e-3);
  expect_identical(off_weights, loose_weights);
  const auto [tight, tight_weights] = run("tight", 1e-4);
  EXPECT_GT(tight.at("A/grad_norm"), 1e-4);
  bool differs = false;
  for (const auto& [name, t] : off_weights) differs = differs || !torch::equal(t, tight_weights.at(name));
  EXPECT_TRUE(differs) << "clipping at 1e-4 left every weight as it was";
  // A finite loss with NaN gradients: the clip's norm stops the run at that step.
  TwoNetTask task;
  task.nan_grad_at = 2 * 5 + 1;  // step 6, phase A
  StreamSource source(2, 0, 1);
  auto o = options(testing::temp_dir() + "/clip_nan", 20);
  o.clip_grad_norm = 1e9;
  try {
    Trainer(o, task, source, nullptr).run();
    FAIL() << "training continued on a NaN gradient";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("A/grad_norm"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("step 6"), std::string::npos) << e.what();
  }
}

TEST(Trainer, ExportsAModuleUnderItsOwnNames) {
  const std::string dir = testing::temp_dir() + "/export";
  TwoNetTask task;
  StreamSource source(2, 0, 1);
  Trainer(options(dir, 2), task, source, nullptr).run();
  export_module(checkpoint_path(dir), "A", dir + "/A.safetensors");
  const auto exported = load_tensors(dir + "/A.safetensors");
  const auto params = task.a->named_parameters();
  EXPECT_EQ(exported.size(), params.size());  // no buffers in A
  for (const auto& p : params) EXPECT_TRUE(torch::equal(exported.at(p.key()), p.value())) << p.key();
  try {
    export_module(checkpoint_path(dir), "G", dir + "/G.safetensors");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("A, B"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir + "/G.safetensors"));
}

TEST(Schedule, Factors) {
  Schedule linear{"linear", 10};
  EXPECT_EQ(linear.factor(5, 20), 1.0);
  EXPECT_DOUBLE_EQ(linear.factor(15, 20), 0.5);
  EXPECT_EQ(linear.factor(20, 20), 0.0);
  Schedule step{"step", 0, 100, 0.2};
  EXPECT_EQ(step.factor(99, 1000), 1.0);
  EXPECT_DOUBLE_EQ(step.factor(250, 1000), 0.04);
  EXPECT_THROW(Schedule{"cosine"}.factor(1, 2), InvalidInput);
  EXPECT_THROW(Schedule{"cosine"}.check(), InvalidInput);
  testing::expect_options_json<Schedule>({{"kind", "step"}, {"decay_start", 5}, {"step_every", 100}, {"gamma", 0.5}});
  EXPECT_THROW(nlohmann::json({{"kind", "cosine"}}).get<Schedule>(), InvalidInput);
  // --lr-decay's fraction: 1 keeps the rate; 0.25 of 10 steps starts the fall at step 3 (2.5 rounded away from 0).
  EXPECT_EQ(Schedule::linear_from(1.0, 10).kind, "constant");
  Schedule quarter = Schedule::linear_from(0.25, 10);
  EXPECT_EQ(quarter.kind, "linear");
  EXPECT_EQ(quarter.decay_start, 3);
  EXPECT_EQ(Schedule::linear_from(0.0, 10).factor(0, 10), 1.0);
  EXPECT_DOUBLE_EQ(Schedule::linear_from(0.0, 10).factor(5, 10), 0.5);
}

// ---- two ranks (Gloo on 127.0.0.1) equal one process on the combined batch ----

constexpr int64_t kDistSteps = 6, kDistBatch = 2;

std::map<std::string, torch::Tensor> train_stream(int rank, int world, dist::Group* group, const std::string& dir) {
  seed_everything(rank == 0 ? 5 : 99);  // rank 1 starts elsewhere: the broadcast must fix it
  TwoNetTask task;
  task.a->ptr(2)->as<torch::nn::Dropout>()->options.p(0);  // dropout masks would differ between ranks
  StreamSource source(kDistBatch * (group ? 1 : world), rank, group ? world : 1);
  auto o = options(dir, kDistSteps);
  o.eval_every = o.sample_every = 0;
  Trainer(o, task, source, nullptr, group).run();
  return weights(task);
}

TEST(Distributed, Worker) {
  const char* out = std::getenv("BARESKIN_DIST_TEST_OUT");
  if (!out) GTEST_SKIP() << "run by Distributed.TwoRanksEqualOneProcess";
  const auto env = dist::Environment::from_env();
  dist::Group group(env, torch::kCPU, 60);
  auto w = train_stream(env.rank, env.world, &group, std::string(out) + "/rank" + std::to_string(env.rank));
  if (env.rank == 0) save_tensors(std::string(out) + "/weights.safetensors", w);
}

TEST(Distributed, TwoRanksEqualOneProcess) {
  const std::string dir = testing::temp_dir();
  const int port = 20000 + int(::getpid() % 20000);
  std::vector<pid_t> children;
  for (int rank = 0; rank < 2; ++rank)
    children.push_back(spawn_self("Distributed.Worker",
                                  {"RANK=" + std::to_string(rank), "WORLD_SIZE=2", "LOCAL_RANK=0", "MASTER_ADDR=127.0.0.1",
                                   "MASTER_PORT=" + std::to_string(port), "BARESKIN_DIST_TEST_OUT=" + dir,
                                   "OMP_NUM_THREADS=1"}));
  for (pid_t pid : children) ASSERT_TRUE(exited_cleanly(pid)) << "a rank failed";
  const auto two = load_tensors(dir + "/weights.safetensors");
  const auto one = train_stream(0, 2, nullptr, dir + "/single");
  ASSERT_EQ(two.size(), one.size());
  for (const auto& [name, t] : one) {
    EXPECT_LE((two.at(name) - t).abs().max().item<double>(), 1e-6) << name;
    EXPECT_GT((t - 0).abs().sum().item<double>(), 0) << name;
  }
  EXPECT_FALSE(fs::exists(dir + "/rank1/checkpoint.safetensors"));  // only rank 0 writes
  EXPECT_TRUE(fs::exists(dir + "/rank0/checkpoint.safetensors"));
}

}  // namespace
}  // namespace bareskin::train
