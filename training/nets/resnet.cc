#include "training/nets/resnet.h"

#include <torch/torch.h>

#include "core/json_options.h"
#include "training/nets/common.h"

namespace bareskin::nets {
namespace nn = torch::nn;
namespace {

const char* kResnet = "resnet";

nn::Conv2d resnet_conv(int64_t in, int64_t out, int64_t k, int64_t stride) {
  return nn::Conv2d(nn::Conv2dOptions(in, out, k).stride(stride).padding(k / 2).bias(false));
}

// torchvision: a 1×1 convolution with the block's stride and a batch norm, when the identity cannot be added.
nn::Sequential make_downsample(int64_t in, int64_t out, int64_t stride) {
  if (stride == 1 && in == out) return nullptr;
  return nn::Sequential(resnet_conv(in, out, 1, stride), nn::BatchNorm2d(out));
}

template <typename Block>
nn::Sequential make_layer(int64_t& in, int64_t planes, int blocks, int64_t stride) {
  nn::Sequential layer;
  for (int i = 0; i < blocks; ++i) {
    layer->push_back(Block(in, planes, i == 0 ? stride : 1));
    in = planes * Block::ContainedType::kExpansion;
  }
  return layer;
}

}  // namespace

void ResNetOptions::check() const {
  const ResNetOptions& o = *this;
  const bool known_depth = o.depth == 18 || o.depth == 34 || o.depth == 50;
  require(known_depth, kResnet, "depth " + std::to_string(o.depth) + " is not built", "use 18, 34 or 50");
  require(o.width >= 1 && o.in_channels >= 1 && o.num_classes >= 0, kResnet,
          "width and in_channels must be positive and num_classes not negative", "fix the options");
}

// The keys of ResNetOptions, listed once (core/json_options.h).
const auto kResNetFields = [](auto& v, auto& o) {
  v("depth", o.depth);
  v("width", o.width);
  v("num_classes", o.num_classes);
  v("in_channels", o.in_channels);
};

void to_json(nlohmann::json& j, const ResNetOptions& o) { json_options::write(j, o, kResNetFields); }
void from_json(const nlohmann::json& j, ResNetOptions& o) { json_options::read(j, o, "resnet", kResNetFields); }

BasicBlockImpl::BasicBlockImpl(int64_t in, int64_t planes, int64_t stride) {
  conv1_ = register_module("conv1", resnet_conv(in, planes, 3, stride));
  bn1_ = register_module("bn1", nn::BatchNorm2d(planes));
  conv2_ = register_module("conv2", resnet_conv(planes, planes, 3, 1));
  bn2_ = register_module("bn2", nn::BatchNorm2d(planes));
  downsample_ = make_downsample(in, planes, stride);
  if (downsample_) register_module("downsample", downsample_);
}

torch::Tensor BasicBlockImpl::forward(torch::Tensor x) {
  torch::Tensor out = torch::relu(bn1_(conv1_(x)));
  out = bn2_(conv2_(out));
  return torch::relu(out + (downsample_ ? downsample_->forward(x) : x));
}

BottleneckImpl::BottleneckImpl(int64_t in, int64_t planes, int64_t stride) {
  conv1_ = register_module("conv1", resnet_conv(in, planes, 1, 1));
  bn1_ = register_module("bn1", nn::BatchNorm2d(planes));
  conv2_ = register_module("conv2", resnet_conv(planes, planes, 3, stride));
  bn2_ = register_module("bn2", nn::BatchNorm2d(planes));
  conv3_ = register_module("conv3", resnet_conv(planes, planes * kExpansion, 1, 1));
  bn3_ = register_module("bn3", nn::BatchNorm2d(planes * kExpansion));
  downsample_ = make_downsample(in, planes * kExpansion, stride);
  if (downsample_) register_module("downsample", downsample_);
}

torch::Tensor BottleneckImpl::forward(torch::Tensor x) {
  torch::Tensor out = torch::relu(bn1_(conv1_(x)));
  out = torch::relu(bn2_(conv2_(out)));
  out = bn3_(conv3_(out));
  return torch::relu(out + (downsample_ ? downsample_->forward(x) : x));
}

ResNetImpl::ResNetImpl(const ResNetOptions& o) : options_(o) {
  o.check();
  conv1_ = register_module("conv1",
                           nn::Conv2d(nn::Conv2dOptions(o.in_channels, o.width, 7).stride(2).padding(3).bias(false)));
  bn1_ = register_module("bn1", nn::BatchNorm2d(o.width));
  const int blocks[3][4] = {{2, 2, 2, 2}, {3, 4, 6, 3}, {3, 4, 6, 3}};
  const int* n = blocks[o.depth == 18 ? 0 : o.depth == 34 ? 1 : 2];
  int64_t in = o.width;
  for (int i = 0; i < 4; ++i) {
    const int64_t planes = int64_t(o.width) << i, stride = i == 0 ? 1 : 2;
    layers_[i] = o.depth == 50 ? make_layer<Bottleneck>(in, planes, n[i], stride)
                               : make_layer<BasicBlock>(in, planes, n[i], stride);
    register_module("layer" + std::to_string(i + 1), layers_[i]);
  }
  feature_channels_ = in;
  if (o.num_classes > 0) fc_ = register_module("fc", nn::Linear(in, o.num_classes));
  // torchvision's initialisation: He normal (fan out) for convolutions, batch norms at identity; fc keeps the
  // default (uniform ±1/sqrt(fan_in)), as torchvision's.
  torch::NoGradGuard no_grad;
  apply([](nn::Module& m) {
    if (auto* c = m.as<nn::Conv2d>()) nn::init::kaiming_normal_(c->weight, 0.0, torch::kFanOut, torch::kReLU);
    if (auto* b = m.as<nn::BatchNorm2d>()) {
      b->weight.fill_(1.0);
      b->bias.zero_();
    }
  });
}

torch::Tensor ResNetImpl::trunk(torch::Tensor x) {
  x = torch::relu(bn1_(conv1_(x)));
  x = torch::max_pool2d(x, 3, 2, 1);
  for (auto& layer : layers_) x = layer->forward(x);
  return x;
}

torch::Tensor ResNetImpl::features(torch::Tensor x) {
  return torch::adaptive_avg_pool2d(trunk(x), {1, 1}).flatten(1);  // as torchvision (same kernel, same sums)
}

torch::Tensor ResNetImpl::forward(torch::Tensor x) {
  torch::Tensor f = features(x);
  return fc_ ? fc_(f) : f;
}

}  // namespace bareskin::nets
