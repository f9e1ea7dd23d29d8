// Super-resolution ×4 for BareSkinNet's 4K textures, in BasicSR's layout and names:
// - MSRResNet (BasicSR's "modified SRResNet": SRResNet without batch norm): conv_first, body (num_block residual
//   blocks conv1 → ReLU → conv2, no BN), upconv1 (+ upconv2 for ×4) each followed by a ×2 pixel shuffle and
//   LeakyReLU 0.1, conv_hr, conv_last; the output is added to the bilinearly upsampled input. Weights start as
//   BasicSR's (He normal ×0.1, biases 0). Ours: `base` "bicubic" adds the output to the bicubically upsampled
//   input instead and starts conv_last at zero (the convolutions outside the residual blocks at He normal's full
//   scale), so the untrained net is exactly bicubic and learns the residual over it.
// - VGGStyleDiscriminator (SRGAN's discriminator as BasicSR builds it for 128² or 256² inputs): pairs conv{k}_0
//   (3×3, stride 1) / conv{k}_1 (4×4, stride 2) with batch norms bn{k}_{0,1} (none after conv0_0, which has the only
//   bias), LeakyReLU 0.2, then linear1 (→100) and linear2 (→1).
#pragma once
#include <torch/nn.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace bareskin::nets {

struct MSRResNetOptions {
  int num_in_ch = 3;
  int num_out_ch = 3;  // = num_in_ch (the output is a residual over the upsampled input)
  int num_feat = 64;
  int num_block = 16;
  int upscale = 4;  // 2 | 3 | 4
  std::string base = "bilinear";  // the upsampling the output is a residual over: bilinear (BasicSR) | bicubic
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const MSRResNetOptions& o);
void from_json(const nlohmann::json& j, MSRResNetOptions& o);

struct VGGStyleDiscriminatorOptions {
  int num_in_ch = 3;
  int num_feat = 64;
  int input_size = 128;  // 128 | 256: the only input size the linear head accepts
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const VGGStyleDiscriminatorOptions& o);
void from_json(const nlohmann::json& j, VGGStyleDiscriminatorOptions& o);

class ResidualBlockNoBNImpl : public torch::nn::Module {
 public:
  explicit ResidualBlockNoBNImpl(int64_t num_feat);
  torch::Tensor forward(torch::Tensor x);

 private:
  torch::nn::Conv2d conv1_{nullptr}, conv2_{nullptr};
};
TORCH_MODULE(ResidualBlockNoBN);

class MSRResNetImpl : public torch::nn::Module {
 public:
  explicit MSRResNetImpl(const MSRResNetOptions& options = {});
  // [N, num_in_ch, H, W] → [N, num_out_ch, H·upscale, W·upscale]: upsample(features(x), x).
  torch::Tensor forward(torch::Tensor x);
  // The two halves, so inference can run the low-resolution trunk once over a whole map and the upsampling tail in
  // tiles: features = body(lrelu(conv_first(x))) at the input's size ([N, num_feat, H, W]); upsample = upconv1 (+
  // upconv2) with pixel shuffles, conv_hr, conv_last, plus the base upsampling of x. Each output pixel of the tail
  // depends on features and x within 2 input pixels (one 3×3 conv at 1×, one at 2×, two at 4×; bicubic's 4 taps).
  torch::Tensor features(const torch::Tensor& x);
  torch::Tensor upsample(const torch::Tensor& features, const torch::Tensor& x);
  const MSRResNetOptions& options() const { return options_; }

 private:
  MSRResNetOptions options_;
  torch::nn::Conv2d conv_first_{nullptr}, upconv1_{nullptr}, upconv2_{nullptr}, conv_hr_{nullptr}, conv_last_{nullptr};
  torch::nn::Sequential body_{nullptr};
};
TORCH_MODULE(MSRResNet);

class VGGStyleDiscriminatorImpl : public torch::nn::Module {
 public:
  explicit VGGStyleDiscriminatorImpl(const VGGStyleDiscriminatorOptions& options = {});
  // [N, num_in_ch, input_size, input_size] → [N, 1] logits; InvalidInput for another size.
  torch::Tensor forward(torch::Tensor x);
  const VGGStyleDiscriminatorOptions& options() const { return options_; }

 private:
  VGGStyleDiscriminatorOptions options_;
  torch::nn::Conv2d conv0_0_{nullptr};
  std::vector<torch::nn::Conv2d> convs_;       // conv0_1, conv1_0, conv1_1, ...
  std::vector<torch::nn::BatchNorm2d> norms_;  // bn0_1, bn1_0, bn1_1, ...
  torch::nn::Linear linear1_{nullptr}, linear2_{nullptr};
};
TORCH_MODULE(VGGStyleDiscriminator);

}  // namespace bareskin::nets
