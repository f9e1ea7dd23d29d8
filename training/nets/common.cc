#include "training/nets/common.h"

#include <torch/torch.h>

#include "core/error.h"

namespace bareskin::nets {

void require(bool condition, const std::string& what, const std::string& message, const std::string& hint) {
  if (!condition) throw InvalidInput(what + " options", message, hint);
}

void check_norm(const std::string& norm, const std::string& what, bool allow_none) {
  const bool ok = norm == "batch" || norm == "instance" || (allow_none && norm == "none");
  require(ok, what, "norm '" + norm + "' is not known",
          allow_none ? "use batch, instance or none" : "use batch or instance");
}

void push_norm(torch::nn::Sequential& seq, const std::string& norm, int64_t channels) {
  if (norm == "batch") {
    seq->push_back(torch::nn::BatchNorm2d(channels));
  } else if (norm == "instance") {
    seq->push_back(torch::nn::InstanceNorm2d(torch::nn::InstanceNorm2dOptions(channels)));
  } else {
    seq->push_back(torch::nn::Identity());
  }
}

void init_normal_002(torch::nn::Module& module) {
  torch::NoGradGuard no_grad;
  module.apply([](torch::nn::Module& m) {
    const bool conv = m.as<torch::nn::Conv2d>() || m.as<torch::nn::ConvTranspose2d>() || m.as<torch::nn::Linear>();
    const bool bn = m.as<torch::nn::BatchNorm2d>() != nullptr;
    if (!conv && !bn) return;
    for (auto& p : m.named_parameters(false)) {
      if (p.key() == "weight") {
        p.value().normal_(bn ? 1.0 : 0.0, 0.02);
      } else if (p.key() == "bias") {
        p.value().zero_();
      }
    }
  });
}

int64_t parameter_count(const torch::nn::Module& module) {
  int64_t n = 0;
  for (const auto& p : module.parameters(true)) n += p.numel();
  return n;
}

}  // namespace bareskin::nets
