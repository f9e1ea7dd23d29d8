// safetensors <-> torch::Tensor: how checkpoints, dataset shards and the template reach the Torch side (which has
// no OpenMesh/OpenImageIO on the GPU machine). Plain LibTorch API common to 1.13 and 2.x.
#pragma once
#include <torch/types.h>

#include <map>
#include <string>

#include "core/safetensors.h"

namespace bareskin {

// Copies a view into a new CPU tensor of the same dtype and shape. InvalidInput for dtypes LibTorch lacks (U16/U32/U64).
torch::Tensor to_tensor(const TensorView& view, const std::string& source = "");

// Adds a tensor (any device, made contiguous and copied to CPU) to a writer.
void add_tensor(SafeTensorsWriter& writer, const std::string& name, const torch::Tensor& tensor);

// Every tensor of a file, by name.
std::map<std::string, torch::Tensor> load_tensors(const std::string& path);

// Writes tensors and metadata atomically.
void save_tensors(const std::string& path, const std::map<std::string, torch::Tensor>& tensors,
                  const std::map<std::string, std::string>& metadata = {});

}  // namespace bareskin
