// TensorFlow.js weight files: a JSON manifest (groups of named tensors with shapes, dtypes and optional
// quantisation) and the binary shards it lists, concatenated in order. Tensors come back dequantised, float32, in
// TensorFlow's layout (convolution filters HWIO); converting them for LibTorch is the network's business.
#pragma once
#include <torch/types.h>

#include <map>
#include <string>

namespace bareskin::detect {

// Reads `manifest` and its shards (paths relative to the manifest's folder). Supports float32/int32 tensors stored
// as float32, int32, or quantised uint8/uint16 (value = q·scale + min) and float16. InvalidInput naming the file for
// malformed JSON, unknown dtypes, or shards shorter or longer than the manifest says; IoError for missing shards.
std::map<std::string, torch::Tensor> read_tfjs_weights(const std::string& manifest);

}  // namespace bareskin::detect
