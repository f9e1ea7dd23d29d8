// VGG16's convolutional trunk (Simonyan & Zisserman 2015) up to relu5_3, laid out and named as torchvision's
// `vgg16().features[:30]` (tensors features.{0,2,5,7,10,12,14,17,19,21,24,26,28}.{weight,bias}), so a torchvision
// state dict's `features.*` entries load unchanged. Used as a perceptual-loss trunk (training/lpips.h).
#pragma once
#include <torch/nn/module.h>
#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/pimpl.h>
#include <torch/types.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace bareskin::losses {

class Vgg16FeaturesImpl : public torch::nn::Module {
 public:
  // The seed of the "vgg16-random" trunk (the year of Liu et al., CVPR 2021, who found random-weight VGG features
  // on par with trained ones for perceptual losses).
  static constexpr uint64_t kRandomSeed = 2021;

  // Weights start as random_init(kRandomSeed). All parameters are frozen (requires_grad false): gradients flow to
  // the input only.
  Vgg16FeaturesImpl();

  // Kaiming normal init (fan_out, ReLU gain: std = sqrt(2 / (out_channels·3·3))), biases 0: the 13 conv weights are
  // filled in layer order with normal_(0, std) from one CPU generator seeded `seed` (in Python:
  // g = torch.Generator().manual_seed(seed); conv.weight.normal_(0, std, generator=g) for each conv in order).
  void random_init(uint64_t seed);

  // images [B, 3, H, W] RGB in [0, 1] (H, W ≥ 16), normalised by ImageNet's mean (0.485, 0.456, 0.406) and std
  // (0.229, 0.224, 0.225) → relu1_2, relu2_2, relu3_3, relu4_3, relu5_3 (64, 128, 256, 512, 512 channels at 1, 1/2,
  // 1/4, 1/8, 1/16 of the input size).
  std::vector<torch::Tensor> forward(const torch::Tensor& images);
  static std::vector<int64_t> channels() { return {64, 128, 256, 512, 512}; }

  // The weights by torchvision name; load_weights takes them back (InvalidInput naming `source` and the tensor when
  // one is missing or of another shape).
  std::map<std::string, torch::Tensor> weights() const;
  void load_weights(const std::map<std::string, torch::Tensor>& weights, const std::string& source);

 private:
  torch::nn::Sequential features_;
};
TORCH_MODULE(Vgg16Features);

}  // namespace bareskin::losses
