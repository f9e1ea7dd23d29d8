#include "training/losses.h"

#include <torch/torch.h>

#include "core/error.h"

namespace bareskin::losses {
namespace F = torch::nn::functional;

torch::Tensor l1(const torch::Tensor& a, const torch::Tensor& b) { return (a - b).abs().mean(); }

torch::Tensor masked_l1(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& mask) {
  const torch::Tensor m = mask.to(a.dtype()).expand_as(a);
  return ((a - b).abs() * m).sum() / m.sum().clamp_min(1e-12);
}

GanKind parse_gan_kind(const std::string& name, const std::string& source) {
  if (name == "vanilla") return GanKind::Vanilla;
  if (name == "lsgan") return GanKind::Lsgan;
  if (name == "hinge") return GanKind::Hinge;
  throw InvalidInput(source, "unknown GAN loss '" + name + "'", "use vanilla, lsgan or hinge");
}

std::string gan_kind_name(GanKind kind) {
  switch (kind) {
    case GanKind::Vanilla:
      return "vanilla";
    case GanKind::Lsgan:
      return "lsgan";
    case GanKind::Hinge:
      return "hinge";
  }
  return "?";
}

torch::Tensor gan_loss(const torch::Tensor& prediction, bool target_is_real, GanKind kind, bool for_discriminator) {
  const double target = target_is_real ? 1 : 0;
  switch (kind) {
    case GanKind::Vanilla:
      return F::binary_cross_entropy_with_logits(prediction, torch::full_like(prediction, target));
    case GanKind::Lsgan:
      return F::mse_loss(prediction, torch::full_like(prediction, target));
    case GanKind::Hinge:
      if (for_discriminator)
        return target_is_real ? torch::relu(1 - prediction).mean() : torch::relu(1 + prediction).mean();
      BS_CHECK(target_is_real, "the generator's hinge loss is defined for target_is_real = true only");
      return -prediction.mean();
  }
  BS_CHECK(false, "unknown GanKind");
  return {};
}

torch::Tensor gan_loss(const MultiscaleOutputs& outputs, bool target_is_real, GanKind kind, bool for_discriminator) {
  BS_CHECK(!outputs.empty(), "gan_loss needs at least one discriminator output");
  torch::Tensor total;
  for (const auto& scale : outputs) {
    BS_CHECK(!scale.empty(), "a discriminator scale without outputs");
    const torch::Tensor loss = gan_loss(scale.back(), target_is_real, kind, for_discriminator);
    total = total.defined() ? total + loss : loss;
  }
  return total;
}

torch::Tensor feature_matching(const MultiscaleOutputs& fake, const MultiscaleOutputs& real, double lambda_feat) {
  if (fake.size() != real.size() || fake.empty())
    throw InvalidInput("feature matching",
                       "fake and real outputs have " + std::to_string(fake.size()) + " and " +
                           std::to_string(real.size()) + " discriminator scales",
                       "pass the outputs of one multiscale discriminator for both");
  const double d_weight = 1.0 / double(fake.size());
  torch::Tensor total = torch::zeros({}, fake[0].back().options());
  for (size_t i = 0; i < fake.size(); ++i) {
    if (fake[i].size() != real[i].size() || fake[i].size() < 2)
      throw InvalidInput("feature matching",
                         "scale " + std::to_string(i) + " has " + std::to_string(fake[i].size()) + " fake and " +
                             std::to_string(real[i].size()) + " real outputs",
                         "the discriminator must return its intermediate features (getIntermFeat)");
    const size_t layers = fake[i].size() - 1;  // n_layers_D + 1 features, then the prediction
    const double feat_weight = 4.0 / double(layers);
    for (size_t j = 0; j < layers; ++j)
      total = total + d_weight * feat_weight * lambda_feat * l1(fake[i][j], real[i][j].detach());
  }
  return total;
}

}  // namespace bareskin::losses
