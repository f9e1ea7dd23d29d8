#include "training/nets/msrresnet.h"

#include <torch/torch.h>

#include <algorithm>

#include "core/error.h"
#include "core/json_options.h"
#include "training/nets/common.h"

namespace bareskin::nets {
namespace nn = torch::nn;
namespace F = torch::nn::functional;
namespace {

nn::Conv2d msr_conv(int64_t in, int64_t out, int64_t k, int64_t stride, bool bias = true) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, k).stride(stride).padding(1).bias(bias));
}

// BasicSR's default_init_weights: He normal (fan in), scaled, biases 0.
void init_scaled(const nn::Conv2d& c, double scale) {
  torch::NoGradGuard no_grad;
  nn::init::kaiming_normal_(c->weight);
  c->weight.mul_(scale);
  if (c->bias.defined()) c->bias.zero_();
}

torch::Tensor lrelu(const torch::Tensor& x, double slope) {
  return F::leaky_relu(x, F::LeakyReLUFuncOptions().negative_slope(slope));
}
torch::Tensor lrelu_(torch::Tensor x, double slope) { return torch::leaky_relu_(x, slope); }

}  // namespace

void MSRResNetOptions::check() const {
  const MSRResNetOptions& o = *this;
  const std::string w = "msrresnet";
  require(o.num_in_ch >= 1 && o.num_out_ch >= 1 && o.num_feat >= 1 && o.num_block >= 0, w,
          "channel counts must be positive and num_block not negative", "fix the options");
  require(o.num_in_ch == o.num_out_ch, w, "num_out_ch must equal num_in_ch",
          "the output is added to the upsampled input; give both the same channel count");
  require(o.upscale >= 2 && o.upscale <= 4, w, "upscale " + std::to_string(o.upscale) + " is not built",
          "use 2, 3 or 4");
  require(o.base == "bilinear" || o.base == "bicubic", w, "base '" + o.base + "' is not built", "use bilinear or bicubic");
}

// The keys of MSRResNetOptions, listed once (core/json_options.h).
const auto kMSRResNetFields = [](auto& v, auto& o) {
  v("num_in_ch", o.num_in_ch);
  v("num_out_ch", o.num_out_ch);
  v("num_feat", o.num_feat);
  v("num_block", o.num_block);
  v("upscale", o.upscale);
  v("base", o.base);
};

void to_json(nlohmann::json& j, const MSRResNetOptions& o) { json_options::write(j, o, kMSRResNetFields); }
void from_json(const nlohmann::json& j, MSRResNetOptions& o) {
  json_options::read(j, o, "msrresnet", kMSRResNetFields);
}

void VGGStyleDiscriminatorOptions::check() const {
  const VGGStyleDiscriminatorOptions& o = *this;
  const std::string w = "srgan_d";
  require(o.input_size == 128 || o.input_size == 256, w, "input_size " + std::to_string(o.input_size) + " is not built",
          "use 128 or 256");
  require(o.num_in_ch >= 1 && o.num_feat >= 1, w, "channel counts must be positive", "fix the options");
}

// The keys of VGGStyleDiscriminatorOptions, listed once (core/json_options.h).
const auto kVGGStyleDiscriminatorFields = [](auto& v, auto& o) {
  v("num_in_ch", o.num_in_ch);
  v("num_feat", o.num_feat);
  v("input_size", o.input_size);
};

void to_json(nlohmann::json& j, const VGGStyleDiscriminatorOptions& o) {
  json_options::write(j, o, kVGGStyleDiscriminatorFields);
}
void from_json(const nlohmann::json& j, VGGStyleDiscriminatorOptions& o) {
  json_options::read(j, o, "srgan_d", kVGGStyleDiscriminatorFields);
}

ResidualBlockNoBNImpl::ResidualBlockNoBNImpl(int64_t num_feat) {
  conv1_ = register_module("conv1", msr_conv(num_feat, num_feat, 3, 1));
  conv2_ = register_module("conv2", msr_conv(num_feat, num_feat, 3, 1));
  init_scaled(conv1_, 0.1);
  init_scaled(conv2_, 0.1);
}

// In place where autograd allows it (a convolution's backward reads its input, not its output).
torch::Tensor ResidualBlockNoBNImpl::forward(torch::Tensor x) {
  torch::Tensor h = conv1_(x);
  torch::relu_(h);
  return conv2_(h).add_(x);
}

MSRResNetImpl::MSRResNetImpl(const MSRResNetOptions& o) : options_(o) {
  o.check();
  conv_first_ = register_module("conv_first", msr_conv(o.num_in_ch, o.num_feat, 3, 1));
  body_ = nn::Sequential();
  for (int i = 0; i < o.num_block; ++i) body_->push_back(ResidualBlockNoBN(o.num_feat));
  register_module("body", body_);
  const int64_t r = o.upscale == 4 ? 2 : o.upscale;
  upconv1_ = register_module("upconv1", msr_conv(o.num_feat, o.num_feat * r * r, 3, 1));
  if (o.upscale == 4) upconv2_ = register_module("upconv2", msr_conv(o.num_feat, o.num_feat * 4, 3, 1));
  conv_hr_ = register_module("conv_hr", msr_conv(o.num_feat, o.num_feat, 3, 1));
  conv_last_ = register_module("conv_last", msr_conv(o.num_feat, o.num_out_ch, 3, 1));
  if (o.base == "bicubic") {
    // Ours: the untrained net is exactly bicubic (conv_last zero) and the convolutions before it keep He normal's
    // full scale, so the residual's gradient is not damped by five ×0.1 layers (the blocks keep BasicSR's ×0.1).
    for (auto* c : {&conv_first_, &upconv1_, &conv_hr_}) init_scaled(*c, 1.0);
    if (upconv2_) init_scaled(upconv2_, 1.0);
    init_scaled(conv_last_, 0.0);
  } else {
    for (auto* c : {&conv_first_, &upconv1_, &conv_hr_, &conv_last_}) init_scaled(*c, 0.1);
    if (upconv2_) init_scaled(upconv2_, 0.1);
  }
}

torch::Tensor MSRResNetImpl::forward(torch::Tensor x) { return upsample(features(x), x); }

torch::Tensor MSRResNetImpl::features(const torch::Tensor& x) {
  return body_->forward(lrelu_(conv_first_(x), 0.1));
}

// The activations are in place: each follows a convolution or pixel shuffle, whose backward does not read its output.
torch::Tensor MSRResNetImpl::upsample(const torch::Tensor& features, const torch::Tensor& x) {
  const int64_t r = options_.upscale == 4 ? 2 : options_.upscale;
  torch::Tensor out = lrelu_(torch::pixel_shuffle(upconv1_(features), r), 0.1);
  if (upconv2_) out = lrelu_(torch::pixel_shuffle(upconv2_(out), 2), 0.1);
  out = conv_last_(lrelu_(conv_hr_(out), 0.1));
  const double s = options_.upscale;
  auto up = F::InterpolateFuncOptions().scale_factor(std::vector<double>{s, s}).align_corners(false);
  if (options_.base == "bicubic")
    up.mode(torch::kBicubic);
  else
    up.mode(torch::kBilinear);
  return out.add_(F::interpolate(x, up));
}

VGGStyleDiscriminatorImpl::VGGStyleDiscriminatorImpl(const VGGStyleDiscriminatorOptions& o) : options_(o) {
  o.check();
  conv0_0_ = register_module("conv0_0", msr_conv(o.num_in_ch, o.num_feat, 3, 1));
  // Stage k has num_feat·min(2^k, 8) channels; stages 0..4 (128²) or 0..5 (256²) halve the size once each.
  const int stages = o.input_size == 128 ? 5 : 6;
  int64_t in = o.num_feat;
  for (int k = 0; k < stages; ++k) {
    const int64_t c = int64_t(o.num_feat) * std::min(1 << k, 8);
    for (int s = k == 0 ? 1 : 0; s < 2; ++s) {
      const std::string id = std::to_string(k) + "_" + std::to_string(s);
      convs_.push_back(register_module("conv" + id, s == 0 ? msr_conv(in, c, 3, 1, false) : msr_conv(c, c, 4, 2, false)));
      norms_.push_back(register_module("bn" + id, nn::BatchNorm2d(c)));
      in = c;
    }
  }
  linear1_ = register_module("linear1", nn::Linear(in * 4 * 4, 100));
  linear2_ = register_module("linear2", nn::Linear(100, 1));
}

torch::Tensor VGGStyleDiscriminatorImpl::forward(torch::Tensor x) {
  const int64_t s = options_.input_size;
  if (x.dim() != 4 || x.size(1) != options_.num_in_ch || x.size(2) != s || x.size(3) != s)
    throw InvalidInput(
        "srgan_d input", "shape " + c10::str(x.sizes()) + " does not fit",
        "give [N, " + std::to_string(options_.num_in_ch) + ", " + std::to_string(s) + ", " + std::to_string(s) + "]");
  torch::Tensor h = lrelu(conv0_0_(x), 0.2);
  for (size_t i = 0; i < convs_.size(); ++i) h = lrelu(norms_[i](convs_[i](h)), 0.2);
  h = lrelu(linear1_(h.flatten(1)), 0.2);
  return linear2_(h);
}

}  // namespace bareskin::nets
