#include "training/device.h"

#include <torch/cuda.h>

#include <regex>

#include "core/error.h"

namespace bareskin {

torch::Device parse_device(const std::string& text, const std::string& flag, int cuda_devices) {
  static const std::regex form("cpu|cuda(:(0|[1-9][0-9]?))?");
  std::smatch m;
  if (!std::regex_match(text, m, form))
    throw InvalidInput(flag, "'" + text + "' is not a device", std::string("give ") + kDeviceForms);
  if (text == "cpu") return torch::kCPU;
  const int index = m[2].matched ? std::stoi(m[2].str()) : -1;
  if (cuda_devices < 0) cuda_devices = torch::cuda::is_available() ? int(torch::cuda::device_count()) : 0;
  if (cuda_devices == 0)
    throw InvalidInput(flag + " " + text, "CUDA is not available on this machine", "use " + flag + " cpu");
  if (index >= cuda_devices)
    throw InvalidInput(flag + " " + text,
                       "CUDA device " + std::to_string(index) + " is not available (this machine has " +
                           std::to_string(cuda_devices) + ")",
                       "give cuda or cuda:0 to cuda:" + std::to_string(cuda_devices - 1));
  return index < 0 ? torch::Device(torch::kCUDA) : torch::Device(torch::kCUDA, static_cast<c10::DeviceIndex>(index));
}

}  // namespace bareskin
