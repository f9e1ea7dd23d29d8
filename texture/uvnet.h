// The UV net: a generator built for texture maps in a fixed UV layout, beside pix2pixHD's (`--arch uv`). It predicts
// the four maps as a correction of what the inputs already say, so it starts where a renderer without texture
// inference would be and only has to learn the difference:
//   diffuse   = the unwrapped photo where it was seen, the 3DMM albedo elsewhere  (+ Δ; UVFill below)
//   normal    = the flat tangent-space normal (0, 0, 1)                          (+ Δ)
//   roughness, specular = mid-grey                                               (+ Δ)
// Δ is a learnt UV prior (one value per texel and channel: what every face shares at that place of the layout, e.g.
// the oily T-zone's roughness) plus pix2pix's U-Net (training/nets/unet.h) on the 13 input channels, with bilinear
// up-convolutions and no normalisation; both start at zero. docs/texture.md gives the chart it was chosen from.
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>

#include "training/nets/unet.h"

namespace bareskin::texture {

// How the diffuse base fills the texels the photo did not see: with the 3DMM albedo as it is (the default, and what
// runs trained before the option read), or with it scaled per sample and channel so that its mean over the seen texels
// equals the unwrap's there (the fill then carries the photo's level and tint, and the seam at the edge of what was
// seen mostly goes).
enum class UVFill { albedo, matched };

// The base the UV net corrects, from the stacked inputs in [−1, 1] ([B, 13, H, W]): [B, 8, H, W] in [−1, 1].
torch::Tensor uv_base(const torch::Tensor& inputs, UVFill fill = UVFill::albedo);

class UVNetImpl : public torch::nn::Module {
 public:
  // `generator` holds UNetOptions over the zoo's unet256 defaults (in/out channels and the side's levels are set here)
  // and the UV net's own "fill": "albedo" (default) | "matched".
  UVNetImpl(const nlohmann::json& generator, int64_t res);
  torch::Tensor forward(const torch::Tensor& inputs);  // [B, 13, res, res] in [−1, 1] → [B, 8, res, res]

 private:
  UVFill fill_ = UVFill::albedo;
  nets::UNet unet_{nullptr};
  torch::Tensor prior_;  // [1, 8, res, res]
};
TORCH_MODULE(UVNet);

}  // namespace bareskin::texture
