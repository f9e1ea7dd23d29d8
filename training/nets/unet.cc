#include "training/nets/unet.h"

#include <torch/torch.h>

#include "core/error.h"
#include "training/nets/common.h"

namespace bareskin::nets {
namespace nn = torch::nn;
namespace {

const char* kWhat = "unet";

nn::AnyModule upsampler(const UNetOptions& o, int64_t in, int64_t out, bool bias) {
  if (o.upsample == "resize_conv") return nn::AnyModule(ResizeConv(in, out, bias));
  return nn::AnyModule(nn::ConvTranspose2d(nn::ConvTranspose2dOptions(in, out, 4).stride(2).padding(1).bias(bias)));
}

}  // namespace

void to_json(nlohmann::json& j, const UNetOptions& o) {
  j = {{"in_channels", o.in_channels},
       {"out_channels", o.out_channels},
       {"ngf", o.ngf},
       {"num_downs", o.num_downs},
       {"norm", o.norm},
       {"dropout", o.dropout},
       {"upsample", o.upsample}};
}

void from_json(const nlohmann::json& j, UNetOptions& o) {
  check_keys(j, kWhat, {"in_channels", "out_channels", "ngf", "num_downs", "norm", "dropout", "upsample"});
  read_key(j, kWhat, "in_channels", o.in_channels);
  read_key(j, kWhat, "out_channels", o.out_channels);
  read_key(j, kWhat, "ngf", o.ngf);
  read_key(j, kWhat, "num_downs", o.num_downs);
  read_key(j, kWhat, "norm", o.norm);
  read_key(j, kWhat, "dropout", o.dropout);
  read_key(j, kWhat, "upsample", o.upsample);
}

ResizeConvImpl::ResizeConvImpl(int64_t in, int64_t out, bool bias) {
  conv_ = register_module("conv", nn::Conv2d(nn::Conv2dOptions(in, out, 3).padding(1).bias(bias)));
}

torch::Tensor ResizeConvImpl::forward(torch::Tensor x) {
  namespace F = nn::functional;
  x = F::interpolate(x, F::InterpolateFuncOptions()
                            .scale_factor(std::vector<double>{2.0, 2.0})
                            .mode(torch::kBilinear)
                            .align_corners(false));
  return conv_(x);
}

// The reference's UnetSkipConnectionBlock, module for module (indices matter for the names):
//   outermost:    [downconv, submodule, ReLU, upconv(2·inner → outer, bias), Tanh]
//   intermediate: [LeakyReLU, downconv, downnorm, submodule, ReLU, upconv(2·inner → outer), upnorm, (Dropout)]
//   innermost:    [LeakyReLU, downconv, ReLU, upconv(inner → outer), upnorm]
UNetBlockImpl::UNetBlockImpl(Kind kind, int64_t outer, int64_t inner, int64_t input, const UNetOptions& o, bool dropout,
                             nn::AnyModule submodule)
    : outermost_(kind == Kind::outermost) {
  const bool bias = o.norm != "batch";
  auto downconv = nn::Conv2d(nn::Conv2dOptions(input, inner, 4).stride(2).padding(1).bias(bias));
  auto leaky = nn::LeakyReLU(nn::LeakyReLUOptions().negative_slope(0.2));
  model_ = nn::Sequential();
  if (kind == Kind::outermost) {
    model_->push_back(downconv);
    model_->push_back(std::move(submodule));
    model_->push_back(nn::ReLU());
    model_->push_back(upsampler(o, inner * 2, outer, true));
    model_->push_back(nn::Tanh());
  } else if (kind == Kind::innermost) {
    model_->push_back(leaky);
    model_->push_back(downconv);
    model_->push_back(nn::ReLU());
    model_->push_back(upsampler(o, inner, outer, bias));
    push_norm(model_, o.norm, outer);
  } else {
    model_->push_back(leaky);
    model_->push_back(downconv);
    push_norm(model_, o.norm, inner);
    model_->push_back(std::move(submodule));
    model_->push_back(nn::ReLU());
    model_->push_back(upsampler(o, inner * 2, outer, bias));
    push_norm(model_, o.norm, outer);
    if (dropout) model_->push_back(nn::Dropout(0.5));
  }
  register_module("model", model_);
}

torch::Tensor UNetBlockImpl::forward(torch::Tensor x) {
  if (outermost_) return model_->forward(x);
  return torch::cat({x, model_->forward(x)}, 1);
}

UNetImpl::UNetImpl(const UNetOptions& o) : options_(o) {
  check_norm(o.norm, kWhat);
  require(o.upsample == "transpose" || o.upsample == "resize_conv", kWhat, "upsample '" + o.upsample + "' is not known",
          "use transpose or resize_conv");
  require(o.num_downs >= 5 && o.num_downs <= 12, kWhat, "num_downs " + std::to_string(o.num_downs) + " is out of range",
          "use 5 to 12 (8 for 256² inputs)");
  require(o.in_channels >= 1 && o.out_channels >= 1 && o.ngf >= 1, kWhat, "channel counts must be positive",
          "fix in_channels, out_channels or ngf");
  using Kind = UNetBlockImpl::Kind;
  const int64_t g = o.ngf;
  auto block = UNetBlock(Kind::innermost, g * 8, g * 8, g * 8, o, false, nn::AnyModule());
  for (int i = 0; i < o.num_downs - 5; ++i)
    block = UNetBlock(Kind::intermediate, g * 8, g * 8, g * 8, o, o.dropout, nn::AnyModule(block));
  block = UNetBlock(Kind::intermediate, g * 4, g * 8, g * 4, o, false, nn::AnyModule(block));
  block = UNetBlock(Kind::intermediate, g * 2, g * 4, g * 2, o, false, nn::AnyModule(block));
  block = UNetBlock(Kind::intermediate, g, g * 2, g, o, false, nn::AnyModule(block));
  model_ = register_module(
      "model", UNetBlock(Kind::outermost, o.out_channels, g, o.in_channels, o, false, nn::AnyModule(block)));
  init_normal_002(*this);
}

torch::Tensor UNetImpl::forward(torch::Tensor x) {
  const int64_t m = int64_t(1) << options_.num_downs;
  if (x.dim() != 4 || x.size(1) != options_.in_channels || x.size(2) % m || x.size(3) % m)
    throw InvalidInput(
        "unet input", "shape " + c10::str(x.sizes()) + " does not fit",
        "give [N, " + std::to_string(options_.in_channels) + ", H, W] with H and W multiples of " + std::to_string(m));
  return model_->forward(x);
}

}  // namespace bareskin::nets
