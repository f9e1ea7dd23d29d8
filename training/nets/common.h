// What every network of the zoo shares: validation errors in one line (each options struct's check()), the
// normalisation layers by name, and the weight initialisations of the reference implementations. The options go to
// and from JSON through core/json_options.h (an unknown key, a value of the wrong type or a bad value is the user's
// error).
#pragma once
#include <torch/nn.h>

#include <nlohmann/json.hpp>
#include <string>

#include "core/error.h"

namespace bareskin::nets {

// Throws InvalidInput("<what> options", message, hint) when `condition` is false.
void require(bool condition, const std::string& what, const std::string& message, const std::string& hint);

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
}  // namespace bareskin::nets
