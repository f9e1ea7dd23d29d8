// pix2pixHD's networks (Wang et al. 2018), in the reference code's layout and names, for BareSkinNet's texture
// inference at 1K:
// - GlobalGenerator: reflection-padded 7×7 conv, n_downsampling stride-2 3×3 convs, n_blocks residual blocks
//   (reflection pad, 3×3 conv, norm, ReLU, reflection pad, 3×3 conv, norm), as many 3×3 transposed convs up, 7×7 conv,
//   Tanh; instance norm without affine parameters. One Sequential `model` ("model.16.conv_block.1.weight", ...).
// - LocalEnhancer: the global generator without its last three modules (`model`) run at half resolution, plus per
//   enhancer n a front end `model{n}_1` on the full-resolution input and a back end `model{n}_2` (residual blocks,
//   transposed conv, and on the last one the 7×7 conv + Tanh) on the sum of the two.
// - MultiscaleDiscriminator: num_D PatchGAN-style discriminators (4×4 convs, padding 2, LeakyReLU 0.2) on the input
//   downsampled by AvgPool2d(3, 2, 1, count_include_pad = false) between scales. With get_interm_feat every layer is
//   its own Sequential `scale{i}_layer{j}` and forward returns every layer's output per scale (feature matching);
//   without, one Sequential `layer{i}` per scale. Scale num_D − 1 sees the full-resolution input (as the reference).
#pragma once
#include <torch/nn.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace bareskin::nets {

struct GlobalGeneratorOptions {
  int in_channels = 3;
  int out_channels = 3;
  int ngf = 64;
  int n_downsampling = 4;  // the input's sides must be multiples of 2^n_downsampling
  int n_blocks = 9;
  std::string norm = "instance";  // instance | batch
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const GlobalGeneratorOptions& o);
void from_json(const nlohmann::json& j, GlobalGeneratorOptions& o);

struct LocalEnhancerOptions {
  int in_channels = 3;
  int out_channels = 3;
  // Of the enhancer; the global generator inside has ngf·2^n_local_enhancers (64: the reference's 2K set-up).
  int ngf = 32;
  int n_downsample_global = 4;
  int n_blocks_global = 9;
  int n_local_enhancers = 1;
  int n_blocks_local = 3;
  std::string norm = "instance";
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const LocalEnhancerOptions& o);
void from_json(const nlohmann::json& j, LocalEnhancerOptions& o);

struct MultiscaleDiscriminatorOptions {
  int in_channels = 6;  // label (input) channels + output channels
  int ndf = 64;
  int n_layers = 3;
  std::string norm = "instance";
  int num_D = 2;
  bool get_interm_feat = true;  // the reference trains with its feature-matching loss, hence with this on
  bool use_sigmoid = false;     // true for the original (non-LSGAN) loss
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const MultiscaleDiscriminatorOptions& o);
void from_json(const nlohmann::json& j, MultiscaleDiscriminatorOptions& o);

class HDResnetBlockImpl : public torch::nn::Module {
 public:
  HDResnetBlockImpl(int64_t dim, const std::string& norm);
  torch::Tensor forward(torch::Tensor x);

 private:
  torch::nn::Sequential conv_block_{nullptr};
};
TORCH_MODULE(HDResnetBlock);

class GlobalGeneratorImpl : public torch::nn::Module {
 public:
  explicit GlobalGeneratorImpl(const GlobalGeneratorOptions& options = {});
  // [N, in_channels, H, W] → [N, out_channels, H, W] in (−1, 1).
  torch::Tensor forward(torch::Tensor x);
  const GlobalGeneratorOptions& options() const { return options_; }

 private:
  GlobalGeneratorOptions options_;
  torch::nn::Sequential model_{nullptr};
};
TORCH_MODULE(GlobalGenerator);

class LocalEnhancerImpl : public torch::nn::Module {
 public:
  explicit LocalEnhancerImpl(const LocalEnhancerOptions& options = {});
  // [N, in_channels, H, W] → [N, out_channels, H, W]; H, W multiples of 2^(n_downsample_global + n_local_enhancers).
  torch::Tensor forward(torch::Tensor x);
  const LocalEnhancerOptions& options() const { return options_; }

 private:
  LocalEnhancerOptions options_;
  torch::nn::Sequential model_{nullptr};
  std::vector<torch::nn::Sequential> front_, back_;  // model{n}_1, model{n}_2
};
TORCH_MODULE(LocalEnhancer);

class MultiscaleDiscriminatorImpl : public torch::nn::Module {
 public:
  explicit MultiscaleDiscriminatorImpl(const MultiscaleDiscriminatorOptions& options = {});
  // result[s] for scale s (0: full resolution, then ÷2 each): every layer's output (get_interm_feat; the last is the
  // logit map) or the logit map alone.
  std::vector<std::vector<torch::Tensor>> forward(torch::Tensor x);
  const MultiscaleDiscriminatorOptions& options() const { return options_; }

 private:
  MultiscaleDiscriminatorOptions options_;
  std::vector<std::vector<torch::nn::Sequential>> scales_;  // [discriminator][layer group], reference numbering
};
TORCH_MODULE(MultiscaleDiscriminator);

// The reference's downsampling between scales: AvgPool2d(3, stride 2, padding 1, count_include_pad = false).
torch::Tensor downsample_avg(const torch::Tensor& x);

}  // namespace bareskin::nets
