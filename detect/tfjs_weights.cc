#include "detect/tfjs_weights.h"

#include <torch/torch.h>

#include "core/error.h"
#include "detect/tfjs_manifest.h"

namespace bareskin::detect {

std::map<std::string, torch::Tensor> read_tfjs_weights(const std::string& manifest) {
  std::map<std::string, torch::Tensor> tensors;
  for (TfjsTensor& t : read_tfjs_tensors(manifest)) {
    const int64_t count = int64_t(t.is_int ? t.ints.size() : t.values.size());
    torch::Tensor flat = t.is_int ? torch::from_blob(t.ints.data(), {count}, torch::kInt).clone()
                                  : torch::from_blob(t.values.data(), {count}, torch::kFloat).clone();
    tensors.emplace(t.name, flat.reshape(t.shape));
  }
  return tensors;
}

}  // namespace bareskin::detect
