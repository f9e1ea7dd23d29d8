// What every network of the zoo shares: reading an options object from JSON strictly (an unknown key or a value of
// the wrong type is the user's error), validation errors in one line, the normalisation layers by name, and the
// weight initialisations of the reference implementations.
#pragma once
#include <torch/nn.h>

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"

namespace bareskin::nets {

// Throws InvalidInput("<what> options", message, hint) when `condition` is false.
void require(bool condition, const std::string& what, const std::string& message, const std::string& hint);

// Checks that `j` is an object whose keys are all in `known` (InvalidInput naming the unknown key and listing the
// known ones otherwise).
void check_keys(const nlohmann::json& j, const std::string& what, std::initializer_list<const char*> known);

// Reads j[key] into `value` when present (InvalidInput naming the key when its type is wrong).
template <typename T>
void read_key(const nlohmann::json& j, const std::string& what, const char* key, T& value);

// "batch" | "instance" | "none" (InvalidInput for anything else).
void check_norm(const std::string& norm, const std::string& what, bool allow_none = true);

// A normalisation layer for `channels` as the pix2pix family builds it: BatchNorm2d (affine, running statistics),
// InstanceNorm2d (no affine parameters, no running statistics) or Identity. Registered at the same Sequential index
// in every case, so parameter names do not depend on the choice.
void push_norm(torch::nn::Sequential& seq, const std::string& norm, int64_t channels);

// pix2pix / pix2pixHD initialisation: convolution (and transposed convolution, linear) weights ~ N(0, 0.02), biases
// 0; batch-norm weights ~ N(1, 0.02), biases 0.
void init_normal_002(torch::nn::Module& module);

// Parameters (elements) of a module and all its children.
int64_t parameter_count(const torch::nn::Module& module);

template <typename T>
void read_key(const nlohmann::json& j, const std::string& what, const char* key, T& value) {
  const auto it = j.find(key);
  if (it == j.end()) return;
  try {
    value = it->template get<T>();
  } catch (const nlohmann::json::exception&) {
    throw InvalidInput(what + " options", std::string("'") + key + "' has the wrong type (" + it->dump() + ")",
                       "give it the type of the default (see bareskin train --print-model)");
  }
}
}  // namespace bareskin::nets
