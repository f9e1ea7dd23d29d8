// pix2pix's PatchGAN discriminator ("NLayerDiscriminator", Isola et al. 2017): 4×4 convolutions with padding 1,
// n_layers at stride 2 then one at stride 1 (channels ndf·min(2^k, 8)), each but the first followed by a norm and
// LeakyReLU 0.2, then a 1-channel 4×4 convolution: a map of real/fake logits, one per 70×70 patch for n_layers 3.
// Names as the reference: one Sequential `model` ("model.0.weight", "model.2.weight", "model.3.running_mean", ...).
// Convolutions before a batch norm have no bias (as the reference); with norm "none" they have one.
#pragma once
#include <torch/nn.h>

#include <nlohmann/json.hpp>
#include <string>

namespace bareskin::nets {

struct PatchGANOptions {
  int in_channels = 6;  // conditional GAN: the input image and the (real or generated) output, concatenated
  int ndf = 64;
  int n_layers = 3;
  std::string norm = "batch";  // batch | instance | none
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const PatchGANOptions& o);
void from_json(const nlohmann::json& j, PatchGANOptions& o);

class PatchGANImpl : public torch::nn::Module {
 public:
  explicit PatchGANImpl(const PatchGANOptions& options = {});
  // [N, in_channels, H, W] → [N, 1, H', W'] logits (256² → 30² for n_layers 3).
  torch::Tensor forward(torch::Tensor x);
  const PatchGANOptions& options() const { return options_; }

 private:
  PatchGANOptions options_;
  torch::nn::Sequential model_{nullptr};
};
TORCH_MODULE(PatchGAN);

}  // namespace bareskin::nets
