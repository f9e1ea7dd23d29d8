#include "training/vgg16.h"

#include <ATen/CPUGeneratorImpl.h>
#include <torch/torch.h>

#include <cmath>

#include "core/error.h"

namespace bareskin::losses {
namespace {

constexpr int kPool = 0;
// torchvision's configuration "D": channels of each 3×3 conv, 0 for a 2×2 max pool.
constexpr int kConfig[] = {64, 64, kPool, 128, 128, kPool, 256, 256, 256, kPool, 512, 512, 512, kPool, 512, 512, 512};
// Indices into `features` of the relu outputs LPIPS taps: relu1_2, relu2_2, relu3_3, relu4_3, relu5_3.
constexpr int kTaps[] = {3, 8, 15, 22, 29};

}  // namespace

Vgg16FeaturesImpl::Vgg16FeaturesImpl() {
  int64_t in = 3;
  for (int c : kConfig) {
    if (c == kPool) {
      features_->push_back(torch::nn::MaxPool2d(torch::nn::MaxPool2dOptions(2).stride(2)));
      continue;
    }
    features_->push_back(torch::nn::Conv2d(torch::nn::Conv2dOptions(in, c, 3).padding(1)));
    features_->push_back(torch::nn::ReLU());
    in = c;
  }
  register_module("features", features_);
  for (auto& p : parameters()) p.requires_grad_(false);
  random_init(kRandomSeed);
}

void Vgg16FeaturesImpl::random_init(uint64_t seed) {
  torch::NoGradGuard no_grad;
  at::Generator generator = at::detail::createCPUGenerator(seed);
  for (const auto& item : named_parameters()) {
    torch::Tensor p = item.value();
    if (p.dim() == 4) {
      const torch::Tensor w = torch::empty(p.sizes(), torch::kFloat);
      w.normal_(0, std::sqrt(2.0 / double(p.size(0) * p.size(2) * p.size(3))), generator);
      p.copy_(w);
    } else {
      p.zero_();
    }
  }
}

std::vector<torch::Tensor> Vgg16FeaturesImpl::forward(const torch::Tensor& images) {
  TORCH_CHECK(images.dim() == 4 && images.size(1) == 3, "Vgg16Features takes [B, 3, H, W] images, got ",
              images.sizes());
  const auto options = images.options();
  const torch::Tensor mean = torch::tensor({0.485, 0.456, 0.406}, options).view({1, 3, 1, 1});
  const torch::Tensor std = torch::tensor({0.229, 0.224, 0.225}, options).view({1, 3, 1, 1});
  torch::Tensor x = (images - mean) / std;
  std::vector<torch::Tensor> out;
  int index = 0;
  for (auto& layer : *features_) {
    x = layer.forward(x);
    if (std::find(std::begin(kTaps), std::end(kTaps), index) != std::end(kTaps)) out.push_back(x);
    if (++index > kTaps[4]) break;
  }
  return out;
}

std::map<std::string, torch::Tensor> Vgg16FeaturesImpl::weights() const {
  std::map<std::string, torch::Tensor> out;
  for (const auto& item : named_parameters()) out[item.key()] = item.value().detach();
  return out;
}

void Vgg16FeaturesImpl::load_weights(const std::map<std::string, torch::Tensor>& weights, const std::string& source) {
  torch::NoGradGuard no_grad;
  for (const auto& item : named_parameters()) {
    const std::string& name = item.key();
    torch::Tensor p = item.value();
    const auto it = weights.find(name);
    if (it == weights.end())
      throw InvalidInput(source, "has no tensor '" + name + "' of the VGG16 trunk",
                         "write the file with Lpips::save, or convert torchvision's vgg16 features.* tensors");
    if (it->second.sizes() != p.sizes())
      throw InvalidInput(
          source,
          "tensor '" + name + "' has shape " + c10::str(it->second.sizes()) + ", expected " + c10::str(p.sizes()),
          "it must hold a VGG16 trunk");
    p.copy_(it->second);
  }
}

}  // namespace bareskin::losses
