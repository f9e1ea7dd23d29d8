#include "training/nets/zoo.h"

#include <torch/torch.h>

#include "core/error.h"
#include "training/nets/msrresnet.h"
#include "training/nets/patchgan.h"
#include "training/nets/pix2pixhd.h"
#include "training/nets/resnet.h"
#include "training/nets/unet.h"
#include "training/tensor_io.h"

namespace bareskin::nets {
namespace {

// An entry whose options are `Options` (to_json/from_json) with `defaults`, built as `Holder(options)`.
template <typename Holder, typename Options>
ModelEntry entry(std::string name, std::string summary, const Options& defaults) {
  ModelEntry e;
  e.name = std::move(name);
  e.summary = std::move(summary);
  e.defaults = defaults;
  e.make = [defaults](const nlohmann::json& j) -> std::shared_ptr<torch::nn::Module> {
    Options o = defaults;
    from_json(j.is_null() ? nlohmann::json::object() : j, o);
    return Holder(o).ptr();
  };
  return e;
}

std::vector<ModelEntry> build_zoo() {
  ResNetOptions r50;
  r50.depth = 50;
  UNetOptions unet;
  PatchGANOptions patch;
  return {
      entry<ResNet>("resnet18",
                    "ResNet-18 (torchvision layout): BareSkinNet's student E, 3DMM coefficients from photos",
                    ResNetOptions{}),
      entry<ResNet>("resnet50", "ResNet-50 (torchvision layout): BareSkinNet's teacher F, 3DMM coefficients", r50),
      entry<UNet>("unet256", "pix2pix U-Net generator (unet_256): BareSkinNet's generator G, photo to bare skin", unet),
      entry<PatchGAN>("patchgan", "pix2pix PatchGAN discriminator (70x70, n_layers 3) for G", patch),
      entry<GlobalGenerator>("pix2pixhd_global", "pix2pixHD global generator: UV texture maps at 1K",
                             GlobalGeneratorOptions{}),
      entry<LocalEnhancer>("pix2pixhd_local", "pix2pixHD local enhancer around a global generator: 2K",
                           LocalEnhancerOptions{}),
      entry<MultiscaleDiscriminator>("pix2pixhd_multiscale_d",
                                     "pix2pixHD multiscale discriminator with per-layer features (feature matching)",
                                     MultiscaleDiscriminatorOptions{}),
      entry<MSRResNet>("msrresnet", "BasicSR MSRResNet (SRResNet without BN), x4: texture maps 1K to 4K",
                       MSRResNetOptions{}),
      entry<VGGStyleDiscriminator>("srgan_d", "BasicSR VGG-style SRGAN discriminator for 128x128 patches",
                                   VGGStyleDiscriminatorOptions{}),
  };
}

}  // namespace

const std::vector<ModelEntry>& model_zoo() {
  static const std::vector<ModelEntry> zoo = build_zoo();
  return zoo;
}

const ModelEntry& find_model(const std::string& name) {
  std::string names;
  for (const ModelEntry& e : model_zoo()) {
    if (e.name == name) return e;
    names += (names.empty() ? "" : ", ") + e.name;
  }
  throw InvalidInput("model '" + name + "'", "not in the zoo", "use one of " + names);
}

torch::Tensor forward_output(torch::nn::Module& net, const torch::Tensor& x) {
  torch::nn::Module* m = &net;
  if (auto* d = dynamic_cast<MultiscaleDiscriminatorImpl*>(m)) {
    std::vector<torch::Tensor> flat;
    for (const auto& scale : d->forward(x))
      for (const auto& f : scale) flat.push_back(f.flatten());
    return torch::cat(flat);
  }
  if (auto* n = dynamic_cast<ResNetImpl*>(m)) return n->forward(x);
  if (auto* n = dynamic_cast<UNetImpl*>(m)) return n->forward(x);
  if (auto* n = dynamic_cast<PatchGANImpl*>(m)) return n->forward(x);
  if (auto* n = dynamic_cast<GlobalGeneratorImpl*>(m)) return n->forward(x);
  if (auto* n = dynamic_cast<LocalEnhancerImpl*>(m)) return n->forward(x);
  if (auto* n = dynamic_cast<MSRResNetImpl*>(m)) return n->forward(x);
  if (auto* n = dynamic_cast<VGGStyleDiscriminatorImpl*>(m)) return n->forward(x);
  BS_CHECK(false, "forward_output: " + net.name() + " is not a network of the zoo");
  return {};
}

std::map<std::string, torch::Tensor> state_dict(const torch::nn::Module& module) {
  std::map<std::string, torch::Tensor> out;
  for (const auto& p : module.named_parameters(true)) out[p.key()] = p.value().detach().cpu();
  for (const auto& b : module.named_buffers(true)) out[b.key()] = b.value().detach().cpu();
  return out;
}

void export_state_dict(const torch::nn::Module& module, const std::string& path,
                       const std::map<std::string, std::string>& metadata) {
  save_tensors(path, state_dict(module), metadata);
}

void import_state_dict(torch::nn::Module& module, const std::string& path) {
  const std::map<std::string, torch::Tensor> file = load_tensors(path);
  std::map<std::string, torch::Tensor> ours;
  for (const auto& p : module.named_parameters(true)) ours[p.key()] = p.value();
  for (const auto& b : module.named_buffers(true)) ours[b.key()] = b.value();
  for (const auto& [name, t] : file)
    if (!ours.count(name))
      throw InvalidInput(path, "tensor '" + name + "' is not a parameter of the network",
                         "check that the file belongs to this model and its options");
  for (const auto& [name, t] : ours) {
    const auto it = file.find(name);
    if (it == file.end())
      throw InvalidInput(path, "parameter '" + name + "' is missing", "check the model's options (depth, widths)");
    if (it->second.sizes() != t.sizes())
      throw InvalidInput(
          path,
          "parameter '" + name + "' has shape " + c10::str(it->second.sizes()) + ", the network " + c10::str(t.sizes()),
          "check the model's options (depth, widths)");
  }
  torch::NoGradGuard no_grad;
  for (auto& [name, t] : ours) t.copy_(file.at(name));
}

}  // namespace bareskin::nets
