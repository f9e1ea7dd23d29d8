// Training-step cost of every network of the zoo on the CPU: forward, backward of a mean-square of the output, and
// one Adam step, at the paper's sizes (batch 4 at 256² for the ResNets, U-Net and PatchGAN; batch 1 at 1024² for
// pix2pixHD; BasicSR's batch 16 of 32² → 128² patches for MSRResNet and 128² for its discriminator) and at small
// demo sizes. Every size: the first step (cold: allocations, Adam state), then the best and the median of the
// following ones (paper sizes: --steps − 1 of them, default 1; demo sizes: 7). On a shared machine the best step is the
// figure to compare: contention only ever adds time.
//   nets_bench [--paper] [--demo] [--only NAME[,NAME...]] [--steps N] [--threads T]
#include <malloc.h>
#include <torch/torch.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "training/nets/zoo.h"

// One namespace per program: bench/torch_bench.cc runs this main under the name `nets_bench` (one binary, one unity
// translation unit for every Torch bench).
namespace bareskin_bench_nets {

using namespace bareskin::nets;
using J = nlohmann::json;

namespace {

struct Case {
  std::string model, label;
  J options;
  std::vector<int64_t> input;
  bool paper;
};

std::vector<Case> cases() {
  const J demo_unet = {{"ngf", 16}, {"num_downs", 7}};
  return {
      {"resnet18", "paper", J::object(), {4, 3, 256, 256}, true},
      {"resnet18", "demo width 16", {{"width", 16}}, {4, 3, 128, 128}, false},
      {"resnet50", "paper", J::object(), {4, 3, 256, 256}, true},
      {"resnet50", "demo width 16", {{"width", 16}}, {4, 3, 128, 128}, false},
      {"unet256", "paper", J::object(), {4, 3, 256, 256}, true},
      {"unet256", "paper, resize_conv", {{"upsample", "resize_conv"}}, {4, 3, 256, 256}, true},
      {"unet256", "demo ngf 16, 7 downs", demo_unet, {4, 3, 128, 128}, false},
      {"unet256",
       "demo ngf 16, 7 downs, resize_conv",
       {{"ngf", 16}, {"num_downs", 7}, {"upsample", "resize_conv"}},
       {4, 3, 128, 128},
       false},
      {"patchgan", "paper", J::object(), {4, 6, 256, 256}, true},
      {"patchgan", "demo ndf 16", {{"ndf", 16}}, {4, 6, 128, 128}, false},
      {"pix2pixhd_global", "paper (1K)", J::object(), {1, 3, 1024, 1024}, true},
      {"pix2pixhd_global", "demo ngf 16", {{"ngf", 16}}, {1, 3, 256, 256}, false},
      {"pix2pixhd_local", "paper (1K)", J::object(), {1, 3, 1024, 1024}, true},
      {"pix2pixhd_local", "demo ngf 8", {{"ngf", 8}}, {1, 3, 256, 256}, false},
      {"pix2pixhd_multiscale_d", "paper (1K)", J::object(), {1, 6, 1024, 1024}, true},
      {"pix2pixhd_multiscale_d", "demo ndf 16", {{"ndf", 16}}, {1, 6, 256, 256}, false},
      {"msrresnet", "paper (16 × 32² → 128²)", J::object(), {16, 3, 32, 32}, true},
      {"msrresnet", "demo 32 feat, 8 blocks", {{"num_feat", 32}, {"num_block", 8}}, {4, 3, 32, 32}, false},
      {"srgan_d", "paper (16 × 128²)", J::object(), {16, 3, 128, 128}, true},
      {"srgan_d", "demo 16 feat", {{"num_feat", 16}}, {4, 3, 128, 128}, false},
  };
}

double step_ms(torch::nn::Module& net, torch::optim::Adam& adam, const torch::Tensor& x) {
  const auto t0 = std::chrono::steady_clock::now();
  adam.zero_grad();
  forward_output(net, x).square().mean().backward();
  adam.step();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

std::string shape(const std::vector<int64_t>& s) {
  return std::to_string(s[0]) + "×" + std::to_string(s[1]) + "×" + std::to_string(s[2]) + "²";
}

}  // namespace

int main(int argc, char** argv) {
  // OpenMP threads that spin while they wait collapse when the cores are shared (2–25× slower steps measured here
  // beside other builds); libgomp reads the policy when it loads, so the bench restarts itself with it set.
  if (!std::getenv("OMP_WAIT_POLICY")) {
    setenv("OMP_WAIT_POLICY", "PASSIVE", 1);
    execv("/proc/self/exe", argv);
  }
  mallopt(M_MMAP_MAX, 0);  // as the CLI: page faults are expensive on these VMs
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  bool paper = false, demo = false;
  int steps = 2, threads = 2;
  std::string only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--paper")
      paper = true;
    else if (a == "--demo")
      demo = true;
    else if (a == "--only" && i + 1 < argc)
      only = "," + std::string(argv[++i]) + ",";
    else if (a == "--steps" && i + 1 < argc)
      steps = std::max(1, std::atoi(argv[++i]));
    else if (a == "--threads" && i + 1 < argc)
      threads = std::max(1, std::atoi(argv[++i]));
    else {
      std::fprintf(stderr, "usage: nets_bench [--paper] [--demo] [--only NAME[,NAME...]] [--steps N] [--threads T]\n");
      return 2;
    }
  }
  if (!paper && !demo) paper = demo = true;
  torch::set_num_threads(threads);
  std::printf("LibTorch %d threads, OMP_WAIT_POLICY %s; forward + backward + Adam step, float32\n\n",
              torch::get_num_threads(), std::getenv("OMP_WAIT_POLICY"));
  std::printf(
      "| network | size | input | parameters | first step | best step | median step |\n"
      "|---|---|---|---|---|---|---|\n");
  for (const Case& c : cases()) {
    if ((c.paper && !paper) || (!c.paper && !demo)) continue;
    if (!only.empty() && only.find("," + c.model + ",") == std::string::npos) continue;
    torch::manual_seed(1);
    auto net = find_model(c.model).make(c.options);
    net->train();
    torch::optim::Adam adam(net->parameters(), torch::optim::AdamOptions(2e-4).betas({0.5, 0.999}));
    const torch::Tensor x = torch::randn(c.input);
    const double first = step_ms(*net, adam, x);
    std::vector<double> ms;
    const int repeats = c.paper ? steps - 1 : 7;
    for (int i = 0; i < repeats; ++i) ms.push_back(step_ms(*net, adam, x));
    std::string best = "—", median = "—";
    if (!ms.empty()) {
      std::sort(ms.begin(), ms.end());
      best = std::to_string(int64_t(ms.front() + 0.5)) + " ms";
      median = std::to_string(int64_t(ms[ms.size() / 2] + 0.5)) + " ms";
    }
    std::printf("| %s | %s | %s | %lld | %.0f ms | %s | %s |\n", c.model.c_str(), c.label.c_str(),
                shape(c.input).c_str(), static_cast<long long>(parameter_count(*net)), first, best.c_str(),
                median.c_str());
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace bareskin_bench_nets
