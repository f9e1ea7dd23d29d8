// ResNet-18/34/50 in torchvision's layout (He et al. 2016; torchvision's "v1.5": the stride of a bottleneck on its
// 3×3 convolution), so the state dict loads into torchvision.models.resnet18/34/50 as it is:
// conv1, bn1, layer1..layer4 (BasicBlock: conv1, bn1, conv2, bn2; Bottleneck: + conv3, bn3; downsample.0 (1×1 conv),
// downsample.1 (batch norm) where the shape changes), fc. The paper's student E is a ResNet-18 and its teacher F a
// ResNet-50, both regressing the 3DMM coefficients from the pooled features.
#pragma once
#include <torch/nn.h>

#include <nlohmann/json.hpp>

namespace bareskin::nets {

struct ResNetOptions {
  int depth = 18;          // 18 | 34 | 50
  int width = 64;          // channels of conv1 and layer1 (torchvision: 64); layer k has width·2^(k-1) (·4 for 50)
  int num_classes = 1000;  // outputs of fc; 0: no head, forward returns the pooled features
  int in_channels = 3;
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const ResNetOptions& o);
void from_json(const nlohmann::json& j, ResNetOptions& o);

class BasicBlockImpl : public torch::nn::Module {
 public:
  static constexpr int kExpansion = 1;
  BasicBlockImpl(int64_t in, int64_t planes, int64_t stride);
  torch::Tensor forward(torch::Tensor x);

 private:
  torch::nn::Conv2d conv1_{nullptr}, conv2_{nullptr};
  torch::nn::BatchNorm2d bn1_{nullptr}, bn2_{nullptr};
  torch::nn::Sequential downsample_{nullptr};
};
TORCH_MODULE(BasicBlock);

class BottleneckImpl : public torch::nn::Module {
 public:
  static constexpr int kExpansion = 4;
  BottleneckImpl(int64_t in, int64_t planes, int64_t stride);
  torch::Tensor forward(torch::Tensor x);

 private:
  torch::nn::Conv2d conv1_{nullptr}, conv2_{nullptr}, conv3_{nullptr};
  torch::nn::BatchNorm2d bn1_{nullptr}, bn2_{nullptr}, bn3_{nullptr};
  torch::nn::Sequential downsample_{nullptr};
};
TORCH_MODULE(Bottleneck);

class ResNetImpl : public torch::nn::Module {
 public:
  explicit ResNetImpl(const ResNetOptions& options = {});
  // [N, in_channels, H, W] → [N, num_classes], or the pooled features when num_classes is 0.
  torch::Tensor forward(torch::Tensor x);
  // [N, in_channels, H, W] → [N, feature_channels()]: global average of layer4 (what heads attach to).
  torch::Tensor features(torch::Tensor x);
  // [N, in_channels, H, W] → layer4's map [N, feature_channels(), H/32, W/32], before the pooling.
  torch::Tensor trunk(torch::Tensor x);
  int64_t feature_channels() const { return feature_channels_; }
  const ResNetOptions& options() const { return options_; }

 private:
  ResNetOptions options_;
  int64_t feature_channels_ = 0;
  torch::nn::Conv2d conv1_{nullptr};
  torch::nn::BatchNorm2d bn1_{nullptr};
  torch::nn::Sequential layers_[4] = {nullptr, nullptr, nullptr, nullptr};
  torch::nn::Linear fc_{nullptr};
};
TORCH_MODULE(ResNet);

}  // namespace bareskin::nets
