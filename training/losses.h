// Pixel and adversarial losses of the training recipes: L1 (BareSkinNet ×100), GAN losses (pix2pix vanilla,
// pix2pixHD LSGAN, hinge), and pix2pixHD's discriminator feature matching (×10). Every function returns a 0-d tensor
// that keeps the graph. SSIM/PSNR: training/ssim.h; LPIPS and the identity loss: training/lpips.h, training/identity.h.
// Formulas and defaults: docs/training.md, "Losses".
#pragma once
#include <torch/types.h>

#include <string>
#include <vector>

namespace bareskin::losses {

// mean |a − b| over every element.
torch::Tensor l1(const torch::Tensor& a, const torch::Tensor& b);

// L1 over the masked elements: Σ m·|a − b| / Σ m, with the mask broadcast to a's shape (so a [B, 1, H, W] mask counts
// once per channel). Soft masks weight pixels. An empty mask gives 0 (no NaN).
torch::Tensor masked_l1(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask);

enum class GanKind {
  Vanilla,  // pix2pix: binary cross-entropy on logits, target 1 (real) / 0 (fake)
  Lsgan,    // pix2pixHD: mean squared error to 1 / 0
  Hinge,    // discriminator: mean relu(1 − D(real)) + mean relu(1 + D(fake)); generator: −mean D(fake)
};
// "vanilla", "lsgan", "hinge"; InvalidInput naming `source` (e.g. a config key) for anything else.
GanKind parse_gan_kind(const std::string& name, const std::string& source = "gan loss");
std::string gan_kind_name(GanKind kind);

// The loss of one discriminator output (logits, any shape) against a real/fake target. for_discriminator only
// matters for the hinge loss: the generator's hinge term is −mean D(fake) and needs target_is_real = true (as
// pix2pixHD/SPADE: the generator wants its output judged real).
torch::Tensor gan_loss(const torch::Tensor& prediction, bool target_is_real, GanKind kind, bool for_discriminator);

// A multiscale discriminator's outputs: per scale, its intermediate features followed by its prediction (pix2pixHD's
// getIntermFeat layout; a single-scale discriminator is one scale with one element). The GAN loss is summed over the
// scales' predictions (the last element of each), as pix2pixHD.
using MultiscaleOutputs = std::vector<std::vector<torch::Tensor>>;
torch::Tensor gan_loss(const MultiscaleOutputs& outputs, bool target_is_real, GanKind kind, bool for_discriminator);

// pix2pixHD's feature matching: Σ_scales Σ_layers D_weight · feat_weight · L1(fake_feature, real_feature.detach())
// · lambda_feat, over every element but each scale's prediction, with D_weight = 1/num_D and feat_weight =
// 4/(n_layers_D + 1), n_layers_D + 1 being the number of feature layers per scale. Gradients reach `fake` only.
// InvalidInput when the two lists differ in layout.
torch::Tensor feature_matching(const MultiscaleOutputs& fake, const MultiscaleOutputs& real, double lambda_feat = 10);

}  // namespace bareskin::losses
