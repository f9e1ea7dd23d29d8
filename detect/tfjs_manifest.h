// TensorFlow.js weight files without Torch: the JSON manifest (groups of named tensors with shapes, dtypes and optional
// quantisation) and the binary shards it lists, concatenated in order, decoded into plain vectors. tfjs_weights.h
// turns them into LibTorch tensors; the fuzz target (tests/fuzz) drives the decoder directly.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace bareskin::detect {

struct TfjsTensor {
  std::string name;
  std::vector<int64_t> shape;
  bool is_int = false;          // dtype int32: `ints`; float32: `values`
  std::vector<float> values;    // dequantised
  std::vector<int32_t> ints;
};

// The bytes of a shard, given its path as the manifest writes it (relative to the manifest's folder).
using TfjsShardSource = std::function<std::string(const std::string& path)>;

// Decodes a manifest's text; `manifest` names it in errors. Supports float32/int32 tensors stored as float32, int32,
// or quantised uint8/uint16 (value = q·scale + min) and float16. InvalidInput naming the manifest for malformed JSON,
// unknown dtypes, a shard path that leaves the manifest's folder (absolute, or with '..'), a tensor larger than the
// memory limit (core/memory_limit.h), a duplicate name, or shards shorter or longer than the manifest says.
std::vector<TfjsTensor> decode_tfjs_weights(const std::string& manifest_text, const std::string& manifest,
                                            const TfjsShardSource& read_shard);

// Reads `manifest` and its shards from disk (IoError for a missing shard).
std::vector<TfjsTensor> read_tfjs_tensors(const std::string& manifest);

}  // namespace bareskin::detect
