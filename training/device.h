// The --device flag of every command that runs networks: one parser, one error shape.
#pragma once
#include <torch/types.h>

#include <string>

namespace bareskin {

// The forms a device is given in: "cpu", "cuda" (the current CUDA device) or "cuda:N" (device N, 0 to 99).
inline constexpr const char* kDeviceForms = "cpu, cuda or cuda:N";

// `text` as a device. InvalidInput naming `flag` and kDeviceForms for any other text, and saying CUDA is not
// available when `cuda_devices` (-1: this machine's count) holds no device of the index asked for.
torch::Device parse_device(const std::string& text, const std::string& flag = "--device", int cuda_devices = -1);

}  // namespace bareskin
