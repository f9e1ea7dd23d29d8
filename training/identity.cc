#include "training/identity.h"

#include <torch/torch.h>

namespace bareskin::losses {
namespace F = torch::nn::functional;

torch::Tensor identity_distance(detect::FaceRecognitionNet& net, const torch::Tensor& a, const torch::Tensor& b) {
  TORCH_CHECK(a.sizes() == b.sizes(), "identity loss: batches of shapes ", a.sizes(), " and ", b.sizes());
  const torch::Tensor e = net->forward(torch::cat({a, b}));
  const int64_t batch = a.size(0);
  return 1 - F::cosine_similarity(e.slice(0, 0, batch), e.slice(0, batch), F::CosineSimilarityFuncOptions().dim(1));
}

torch::Tensor identity_loss(detect::FaceRecognitionNet& net, const torch::Tensor& a, const torch::Tensor& b) {
  return identity_distance(net, a, b).mean();
}

}  // namespace bareskin::losses
