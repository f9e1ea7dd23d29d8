// face-api's face recognition network (npm @vladmandic/face-api, MIT) in LibTorch, from its TensorFlow.js weights:
// a ResNet-34-like net (dlib's face descriptor architecture) that maps a 150×150 RGB face crop to a 128-d
// descriptor; faces of one person lie within ~0.6 (Euclidean) of each other.
//
// Layers (face-api's names, tensors `<layer>/conv/{filters,bias}` and `<layer>/scale/{weights,biases}`):
//   conv32_down   7×7 conv, stride 2, valid padding, then max pool 3×3 stride 2 (valid)          150² → 72² → 35²
//   conv32_1..3   residual: conv 3×3 + relu, conv 3×3, add input, relu ("same" padding)           35², 32 ch
//   conv64_down   residual down: conv 3×3 stride 2 valid + relu, conv 3×3; shortcut 2×2 average pool
//                 with zero channels appended (and a zero row/column appended to the residual branch when the pool
//                 is one larger)                                                                     17², 64 ch
//   conv64_1..3, conv128_down, conv128_1..2 (8², 128 ch), conv256_down, conv256_1..2 (4², 256 ch),
//   conv256_down_out (2², 256 ch), spatial mean, fc [256 → 128] (no bias).
// Each conv is conv + bias, then the "scale" layer (·weights + biases); we fold the scale into the conv.
// Input as face-api: black padding to a centred square, tfjs's legacy bilinear resize to 150² (source = i·in/out, no
// half-pixel offset), then x·255 − mean RGB (122.782, 117.001, 104.298), /255. Here the input is already in [0, 1],
// so the network sees x − mean/255. Every step is differentiable, so the net can serve as a loss (training/identity.h).
#pragma once
#include <torch/nn/module.h>
#include <torch/nn/pimpl.h>
#include <torch/types.h>

#include <map>
#include <string>
#include <vector>

namespace bareskin::detect {

class FaceRecognitionNetImpl : public torch::nn::Module {
 public:
  static constexpr int kInputSize = 150;
  static constexpr int kEmbeddingSize = 128;
  static constexpr int kFeatureLevels = 5;

  // Reads `folder`/face_recognition_model-weights_manifest.json and its shard. IoError when it is missing (run
  // 'make deps'); InvalidInput naming the file for tensors missing or of the wrong shape.
  explicit FaceRecognitionNetImpl(const std::string& folder);
  // From tensors named and shaped as in face-api's manifest (TensorFlow layout: filters HWIO). `source` names them in
  // errors (a manifest or a safetensors file).
  FaceRecognitionNetImpl(const std::map<std::string, torch::Tensor>& weights, const std::string& source);

  // images: [B, 3, H, W] RGB in [0, 1] (sRGB-encoded, as photos), any size, float or double → [B, 128] descriptors.
  torch::Tensor forward(const torch::Tensor& images);

  struct Output {
    torch::Tensor embedding;              // [B, 128]
    std::vector<torch::Tensor> features;  // kFeatureLevels maps, see forward_features
  };
  // The descriptor and the activations at five depths, for perceptual losses: conv32_down (after relu, before the
  // max pool; 32 ch, 72²), conv32_3 (32 ch, 35²), conv64_3 (64 ch, 17²), conv128_2 (128 ch, 8²), conv256_2 (256 ch,
  // 4²). With `embedding` false the last stage and the fc are skipped (embedding is then undefined).
  Output forward_features(const torch::Tensor& images, bool embedding = true);
  static std::vector<int64_t> feature_channels() { return {32, 32, 64, 128, 256}; }

  // face-api's input pipeline: centred black padding to a square, legacy bilinear resize to 150², minus mean/255 →
  // [B, 3, 150, 150] (differentiable; dtype and device of `images`).
  static torch::Tensor prepare(const torch::Tensor& images);

  // The tensors this net was built from, under face-api's names and shapes (TensorFlow layout): what
  // FaceRecognitionNetImpl(weights, source) takes back.
  std::map<std::string, torch::Tensor> tfjs_weights() const;

 private:
  struct Conv {
    torch::Tensor weight, bias;  // scale folded in; OIHW
  };
  Conv conv(const std::string& name);
  torch::Tensor apply(const torch::Tensor& x, const Conv& c, int stride, bool relu) const;
  torch::Tensor residual(const torch::Tensor& x, const std::string& name) const;
  torch::Tensor residual_down(const torch::Tensor& x, const std::string& name) const;

  std::map<std::string, torch::Tensor> source_;  // face-api's tensors as given (for tfjs_weights)
  std::map<std::string, Conv> convs_;            // "conv32_down", "conv32_1/conv1", ...
  torch::Tensor fc_;                             // [256, 128]
};
TORCH_MODULE(FaceRecognitionNet);

// The manifest's file name inside a face-api weights folder.
inline constexpr const char* kFaceRecognitionManifest = "face_recognition_model-weights_manifest.json";

}  // namespace bareskin::detect
