#include "training/lpips.h"

#include <torch/torch.h>

#include "core/error.h"
#include "core/safetensors.h"
#include "detect/face_api.h"
#include "training/tensor_io.h"

namespace bareskin::losses {
namespace {

constexpr double kEpsilon = 1e-10;
const char* const kVgg16 = "vgg16";
const char* const kFaceRecognition = "face_recognition";
const char* const kFormat = "bareskin.lpips";

// LPIPS's name for level l's linear weights (its lin layers are Dropout, Conv2d(C, 1, 1, bias=False)).
std::string linear_name(size_t level) { return "lin" + std::to_string(level) + ".model.1.weight"; }

// f / sqrt(Σ_c f² + ε), per pixel.
torch::Tensor unit_channels(const torch::Tensor& f) { return f * torch::rsqrt(f.pow(2).sum(1, true) + kEpsilon); }

}  // namespace

LpipsImpl::LpipsImpl(const std::string& trunk, const std::string& face_api_folder) {
  if (trunk == "vgg16-random") {
    use_trunk(Vgg16Features());
  } else if (trunk == "facenet") {
    use_trunk(
        detect::FaceRecognitionNet(face_api_folder.empty() ? detect::default_face_api_folder() : face_api_folder));
  } else {
    throw InvalidInput("lpips trunk", "unknown trunk '" + trunk + "'",
                       "use vgg16-random or facenet, or load a weights file");
  }
  trunk_name_ = trunk;
  set_linear({});
}

void LpipsImpl::use_trunk(Vgg16Features vgg) {
  architecture_ = kVgg16;
  trunk_ = register_module("trunk", vgg.ptr());
  channels_ = Vgg16FeaturesImpl::channels();
  features_ = [vgg](const torch::Tensor& x) mutable { return vgg->forward(x); };
  trunk_weights_ = [vgg] { return vgg->weights(); };
}

void LpipsImpl::use_trunk(detect::FaceRecognitionNet net) {
  architecture_ = kFaceRecognition;
  trunk_ = register_module("trunk", net.ptr());
  channels_ = detect::FaceRecognitionNetImpl::feature_channels();
  features_ = [net](const torch::Tensor& x) mutable { return net->forward_features(x, false).features; };
  trunk_weights_ = [net] { return net->tfjs_weights(); };
}

void LpipsImpl::set_linear(std::vector<torch::Tensor> weights) {
  if (weights.empty())
    for (int64_t c : channels_) weights.push_back(torch::full({c}, 1.0 / double(c)));
  BS_CHECK(weights.size() == channels_.size(), "one linear weight vector per level");
  lin_.clear();
  for (size_t l = 0; l < weights.size(); ++l)
    lin_.push_back(register_buffer("lin" + std::to_string(l), weights[l].to(torch::kFloat).contiguous()));
}

std::shared_ptr<LpipsImpl> LpipsImpl::load(const std::string& path) {
  const SafeTensors file = SafeTensors::open(path);
  auto meta = [&](const std::string& key) {
    const auto it = file.metadata().find(key);
    if (it == file.metadata().end())
      throw InvalidInput(path, "has no '" + key + "' metadata",
                         "it is not an LPIPS weights file (docs/file_formats.md)");
    return it->second;
  };
  if (meta("format") != kFormat)
    throw InvalidInput(path, "has format '" + meta("format") + "'",
                       "LPIPS weights files have format " + std::string(kFormat) + " (docs/file_formats.md)");
  const std::string architecture = meta("architecture");
  std::shared_ptr<LpipsImpl> lpips(new LpipsImpl());
  lpips->trunk_name_ = meta("trunk");
  std::map<std::string, torch::Tensor> tensors;
  for (const std::string& name : file.names()) tensors[name] = to_tensor(file.tensor(name), path);
  if (architecture == kVgg16) {
    Vgg16Features vgg;
    vgg->load_weights(tensors, path);
    lpips->use_trunk(vgg);
  } else if (architecture == kFaceRecognition) {
    lpips->use_trunk(detect::FaceRecognitionNet(tensors, path));
  } else {
    throw InvalidInput(path, "has architecture '" + architecture + "'", "LPIPS trunks are vgg16 or face_recognition");
  }
  std::vector<torch::Tensor> lin;
  for (size_t l = 0; l < lpips->channels_.size(); ++l) {
    const int64_t c = lpips->channels_[l];
    const torch::Tensor w = to_tensor(file.tensor(linear_name(l), DType::F32, {1, c, 1, 1}), path).flatten();
    if ((w < 0).any().item<bool>())
      throw InvalidInput(path, "tensor '" + linear_name(l) + "' has negative weights",
                         "LPIPS's linear weights are non-negative (clamp them at 0)");
    lin.push_back(w);
  }
  lpips->set_linear(lin);
  return lpips;
}

void LpipsImpl::save(const std::string& path) const {
  std::map<std::string, torch::Tensor> tensors = trunk_weights_();
  for (size_t l = 0; l < lin_.size(); ++l) tensors[linear_name(l)] = lin_[l].view({1, -1, 1, 1});
  save_tensors(path, tensors,
               {{"format", kFormat}, {"format_version", "1"}, {"trunk", trunk_name_}, {"architecture", architecture_}});
}

torch::Tensor LpipsImpl::forward(const torch::Tensor& a, const torch::Tensor& b) {
  TORCH_CHECK(a.sizes() == b.sizes() && a.dim() == 4 && a.size(1) == 3, "LPIPS takes two [B, 3, H, W] batches, got ",
              a.sizes(), " and ", b.sizes());
  // Two trunk passes rather than one on the concatenation: a target without gradient then costs no backward.
  const std::vector<torch::Tensor> fa = features_(a), fb = features_(b);
  BS_CHECK(fa.size() == lin_.size(), "the trunk gives one feature map per linear layer");
  torch::Tensor total = torch::zeros({a.size(0)}, a.options());
  for (size_t l = 0; l < fa.size(); ++l) {
    const torch::Tensor d = (unit_channels(fa[l]) - unit_channels(fb[l])).pow(2);
    const torch::Tensor w = lin_[l].to(d.dtype()).view({1, -1, 1, 1});
    total = total + (d * w).sum(1).mean({1, 2});
  }
  return total;
}

}  // namespace bareskin::losses
