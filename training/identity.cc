#include "training/identity.h"

#include <torch/torch.h>

namespace bareskin::losses {
namespace F = torch::nn::functional;

torch::Tensor identity_distance(detect::FaceRecognitionNet& net, const torch::Tensor& a, const torch::Tensor& b) {
  TORCH_CHECK(a.sizes() == b.sizes(), "identity loss: batches of shapes ", a.sizes(), " and ", b.sizes());
  // Two passes: a reference without gradient then costs no backward.
  return 1 - F::cosine_similarity(net->forward(a), net->forward(b), F::CosineSimilarityFuncOptions().dim(1));
}

torch::Tensor identity_loss(detect::FaceRecognitionNet& net, const torch::Tensor& a, const torch::Tensor& b) {
  return identity_distance(net, a, b).mean();
}

}  // namespace bareskin::losses
