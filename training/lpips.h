// LPIPS (Zhang et al., "The Unreasonable Effectiveness of Deep Features as a Perceptual Metric", CVPR 2018) on a
// trunk we can ship (no ImageNet weights exist here):
//   "vgg16-random"  VGG16 with seeded Kaiming-normal weights (training/vgg16.h; Liu et al., CVPR 2021: random-weight
//                   VGG features do about as well as trained ones as a perceptual loss), taps relu1_2 … relu5_3;
//   "facenet"       face-api's face recognition net (detect/face_recognition.h), five depths from conv32_down to
//                   conv256_2; the face crop is resized to 150² inside.
// For each level l with features f (C_l channels): f̂ = f / sqrt(Σ_c f² + ε) per pixel (ε = 1e-10), then
//   LPIPS(a, b) = Σ_l mean_{h,w} Σ_c w_lc (f̂a − f̂b)²,
// with non-negative linear weights w_l (LPIPS's lin layers). Without a weights file w_lc = 1/C_l (the "lin-free"
// variant: the mean squared distance of unit feature vectors). Weights files: docs/file_formats.md, "LPIPS weights".
// Every LPIPS figure must name its trunk: trunk_name().
#pragma once
#include <torch/nn/module.h>
#include <torch/nn/pimpl.h>
#include <torch/types.h>

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "detect/face_recognition.h"
#include "training/vgg16.h"

namespace bareskin::losses {

class LpipsImpl : public torch::nn::Module {
 public:
  // A built-in trunk with lin-free weights: "vgg16-random" (no file needed) or "facenet" (reads face-api's recognition
  // model from `face_api_folder`). InvalidInput for another name.
  explicit LpipsImpl(const std::string& trunk, const std::string& face_api_folder = "");

  // From a weights file (safetensors; trunk and linear weights). InvalidInput naming the file and the tensor when one
  // is missing or misshapen, or a linear weight is negative; IoError when the file cannot be read.
  static std::shared_ptr<LpipsImpl> load(const std::string& path);
  // Writes the trunk and linear weights (atomically).
  void save(const std::string& path) const;

  // a, b: [B, 3, H, W] RGB in [0, 1] → [B] distances (0 for identical images). Gradients reach both inputs; the
  // weights are frozen.
  torch::Tensor forward(const torch::Tensor& a, const torch::Tensor& b);

  // "vgg16-random", "facenet", or the name a weights file gives (e.g. "vgg16-imagenet" for converted weights).
  const std::string& trunk_name() const { return trunk_name_; }
  // "vgg16" or "face_recognition": the trunk's layer layout.
  const std::string& architecture() const { return architecture_; }
  // Per level: [C_l] linear weights.
  const std::vector<torch::Tensor>& linear_weights() const { return lin_; }

 private:
  LpipsImpl() = default;
  void use_trunk(Vgg16Features vgg);
  void use_trunk(detect::FaceRecognitionNet net);
  void set_linear(std::vector<torch::Tensor> weights);  // [C_l] each; lin-free when empty

  std::string trunk_name_, architecture_;
  std::shared_ptr<torch::nn::Module> trunk_;
  std::function<std::vector<torch::Tensor>(const torch::Tensor&)> features_;
  std::function<std::map<std::string, torch::Tensor>()> trunk_weights_;
  std::vector<int64_t> channels_;
  std::vector<torch::Tensor> lin_;
};
TORCH_MODULE(Lpips);

}  // namespace bareskin::losses
