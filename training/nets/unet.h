// pix2pix's U-Net generator (Isola et al. 2017; "unet_256" of the reference code): num_downs stride-2 4×4
// convolutions down to 1×1 and as many 4×4 transposed convolutions up, each level's input concatenated to its
// output (skip connections), batch norm, LeakyReLU 0.2 down / ReLU up, dropout 0.5 in the num_downs − 5 innermost
// 512-channel levels, Tanh at the end. BareSkinNet's generator G.
//
// Names follow the reference's recursion: the generator holds `model`, the outermost block; every block holds a
// Sequential `model` whose index 1 (outermost) or 3 (intermediate) is the next block. Parameter names therefore
// equal the reference's ("model.model.1.model.3.model.1.weight", ...) without any renaming. Convolutions have no
// bias before a batch norm (as the reference); with norm "none" they have one (the reference keeps them biasless).
#pragma once
#include <torch/nn.h>

#include <nlohmann/json.hpp>
#include <memory>
#include <string>
#include <vector>

namespace bareskin::nets {

struct UNetOptions {
  int in_channels = 3;
  int out_channels = 3;
  int ngf = 64;                        // channels after the first convolution; ×2 per level up to ×max_mult
  int num_downs = 8;                   // ≥ 5; the input's sides must be multiples of 2^num_downs (8: 256²)
  std::string norm = "batch";          // batch | instance | none
  bool dropout = true;                 // pix2pix trains with dropout in the innermost levels
  std::string upsample = "transpose";  // transpose (reference) | resize_conv (bilinear ×2 + 3×3 convolution)
  int max_mult = 8;                    // the coarsest levels' width in ngf (8: pix2pix; 16, 32: wider coarse levels)
  bool tanh = true;                    // the output through tanh (pix2pix); false: linear, for nets that add it to a
                                       // base (a residual whose tanh saturates passes no gradient)
  void check() const;  // InvalidInput naming the option and what to do
};
void to_json(nlohmann::json& j, const UNetOptions& o);
void from_json(const nlohmann::json& j, UNetOptions& o);

// Bilinear ×2 then a 3×3 convolution: the resize_conv alternative to a stride-2 transposed convolution (no
// checkerboard pattern; on this machine's BLAS faster than the transposed convolution).
class ResizeConvImpl : public torch::nn::Module {
 public:
  ResizeConvImpl(int64_t in, int64_t out, bool bias);
  torch::Tensor forward(torch::Tensor x);

 private:
  friend class UNetInference;
  torch::nn::Conv2d conv_{nullptr};
};
TORCH_MODULE(ResizeConv);

class UNetInference;

class UNetBlockImpl : public torch::nn::Module {
 public:
  enum class Kind { outermost, intermediate, innermost };
  // outer: channels at this level's input/output (the generator's output channels for the outermost block),
  // inner: channels after this level's downsampling; input: channels of the input (outermost: the image's).
  UNetBlockImpl(Kind kind, int64_t outer, int64_t inner, int64_t input, const UNetOptions& o, bool dropout,
                torch::nn::AnyModule submodule);
  torch::Tensor forward(torch::Tensor x);

 private:
  friend class UNetInference;
  bool outermost_;
  torch::nn::Sequential model_{nullptr};
};
TORCH_MODULE(UNetBlock);

class UNetImpl : public torch::nn::Module {
 public:
  explicit UNetImpl(const UNetOptions& options = {});
  // [N, in_channels, H, W] → [N, out_channels, H, W] in (−1, 1). InvalidInput when H or W is not a multiple of
  // 2^num_downs.
  torch::Tensor forward(torch::Tensor x);
  const UNetOptions& options() const { return options_; }

 private:
  friend class UNetInference;
  UNetOptions options_;
  UNetBlock model_{nullptr};
};
TORCH_MODULE(UNet);

// Zeroes the outermost up-convolution (weights and bias), the net's last layer: its output is then 0 for every input
// (tanh(0)), so a net that adds it to a base (BareSkinNet's residual and affine heads, the UV net) starts at the base.
void zero_last_layer(UNetImpl& net);

// A trained U-Net for inference only: the same function as UNetImpl::forward in eval mode (dropout off, batch norm
// with its running statistics), computed faster on the CPU. Ours, not the reference's:
//  - every batch norm is folded into the convolution before it (w·s, (b − mean)·s + β with s = γ / √(var + ε));
//    instance norm has no fixed statistics and stays a layer;
//  - the 4×4 stride-2 transposed convolutions of the levels at least `phase_min_side` pixels wide are computed as one
//    ordinary 2×2 convolution of the padded input with 4× the output channels, one per output phase (row and
//    column parity), interleaved afterwards (levels with at least 16 output channels; for the last level's 3 the
//    transposed convolution is faster). LibTorch 1.13's CPU transposed convolution is an im2col + BLAS path
//    while its ordinary convolution is mkldnn's (docs/training.md, "BareSkinNet at inference"). 0 = never.
//  - the convolutions' weights are prepacked for mkldnn once (on the CPU);
//  - activations in place where the reference's order allows it.
// The weights are copied: later changes to the module do not reach it. Not differentiable.
class UNetInference {
 public:
  explicit UNetInference(const UNetImpl& net, int64_t phase_min_side = 8);
  // [N, in_channels, H, W] → [N, out_channels, H, W] in (−1, 1); the same checks as UNetImpl::forward.
  torch::Tensor forward(const torch::Tensor& x) const;
  const UNetOptions& options() const { return options_; }
  UNetInference& to(torch::Device device);

 private:
  // A convolution's weights, with mkldnn's prepacked copy of them on the CPU (LibTorch's conv2d reorders the weights
  // on every call otherwise).
  struct Conv {
    torch::Tensor w, b, packed;
    int64_t stride = 1, padding = 0;
    void pack();
    torch::Tensor operator()(const torch::Tensor& x) const;
  };
  struct Level {
    std::shared_ptr<torch::nn::InstanceNorm2dImpl> down_norm;  // an instance norm (not foldable), else null
    torch::Tensor up_w, up_b;            // transposed [in, out, 4, 4] or resize_conv [out, in, 3, 3] (norm folded)
    Conv down, phase;                    // the downsampling convolution (stride 2, padding 1; norm folded), and the
                                         // transposed one (below) as phases: a 2×2
                                         // convolution [4·out, in, 2, 2] with padding 1 (else undefined)
    std::shared_ptr<torch::nn::InstanceNorm2dImpl> up_norm;
    int64_t up_out = 0;
    bool resize_conv = false;
    bool outermost = false, innermost = false;
  };
  torch::Tensor level_forward(size_t i, torch::Tensor x) const;
  torch::Tensor upsample(const Level& l, const torch::Tensor& x) const;
  UNetOptions options_;
  int64_t phase_min_side_;
  std::vector<Level> levels_;  // outermost first
};

}  // namespace bareskin::nets
