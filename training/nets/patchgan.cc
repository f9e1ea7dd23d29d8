#include "training/nets/patchgan.h"

#include <torch/torch.h>

#include <algorithm>

#include "core/json_options.h"
#include "training/nets/common.h"

namespace bareskin::nets {
namespace nn = torch::nn;
namespace {
const char* kPatchgan = "patchgan";

nn::Conv2d conv4(int64_t in, int64_t out, int64_t stride, bool bias) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, 4).stride(stride).padding(1).bias(bias));
}
nn::LeakyReLU leaky() { return nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(0.2)); }
}  // namespace

void PatchGANOptions::check() const {
  const PatchGANOptions& o = *this;
  check_norm(o.norm, kPatchgan);
  require(o.in_channels >= 1 && o.ndf >= 1 && o.n_layers >= 1 && o.n_layers <= 8, kPatchgan,
          "in_channels and ndf must be positive and n_layers in 1..8", "fix the options (pix2pix: 6, 64, 3)");
}

// The keys of PatchGANOptions, listed once (core/json_options.h).
const auto kPatchGANFields = [](auto& v, auto& o) {
  v("in_channels", o.in_channels);
  v("ndf", o.ndf);
  v("n_layers", o.n_layers);
  v("norm", o.norm);
};

void to_json(nlohmann::json& j, const PatchGANOptions& o) { json_options::write(j, o, kPatchGANFields); }
void from_json(const nlohmann::json& j, PatchGANOptions& o) { json_options::read(j, o, "patchgan", kPatchGANFields); }

PatchGANImpl::PatchGANImpl(const PatchGANOptions& o) : options_(o) {
  o.check();
  const bool bias = o.norm != "batch";
  model_ = nn::Sequential(conv4(o.in_channels, o.ndf, 2, true), leaky());
  int64_t mult = 1;
  for (int n = 1; n <= o.n_layers; ++n) {
    const int64_t prev = mult;
    mult = std::min<int64_t>(int64_t(1) << n, 8);
    model_->push_back(conv4(o.ndf * prev, o.ndf * mult, n < o.n_layers ? 2 : 1, bias));
    push_norm(model_, o.norm, o.ndf * mult);
    model_->push_back(leaky());
  }
  model_->push_back(conv4(o.ndf * mult, 1, 1, true));
  register_module("model", model_);
  init_normal_002(*this);
}

torch::Tensor PatchGANImpl::forward(torch::Tensor x) { return model_->forward(x); }

}  // namespace bareskin::nets
