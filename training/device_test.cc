#include "training/device.h"

#include <gtest/gtest.h>
#include <torch/cuda.h>

#include "core/error.h"

namespace bareskin {
namespace {

// The error line parse_device throws for `text` with `cuda_devices` devices ("" when it returns a device).
std::string error_of(const std::string& text, int cuda_devices) {
  try {
    parse_device(text, "--device", cuda_devices);
    return "";
  } catch (const InvalidInput& e) {
    return e.what();
  }
}

TEST(ParseDevice, TakesCpuCudaAndCudaN) {
  EXPECT_EQ(parse_device("cpu", "--device", 0), torch::Device(torch::kCPU));
  EXPECT_EQ(parse_device("cpu", "--device", 2), torch::Device(torch::kCPU));
  EXPECT_EQ(parse_device("cuda", "--device", 1), torch::Device(torch::kCUDA));
  EXPECT_FALSE(parse_device("cuda", "--device", 1).has_index());
  EXPECT_EQ(parse_device("cuda:0", "--device", 1), torch::Device(torch::kCUDA, 0));
  EXPECT_EQ(parse_device("cuda:3", "--device", 4), torch::Device(torch::kCUDA, 3));
  EXPECT_EQ(parse_device("cuda:10", "--device", 11), torch::Device(torch::kCUDA, 10));
}

TEST(ParseDevice, OtherTextNamesTheFlagAndTheForms) {
  for (const std::string bad : {"", "gpu", "CUDA", "cuda:", "cuda:-1", "cuda:01", "cuda:1:2", "cuda:x", "cuda 0",
                                " cpu", "cpu:0", "cuda:100", "mps"}) {
    EXPECT_EQ(error_of(bad, 8), "--device: '" + bad + "' is not a device; give cpu, cuda or cuda:N") << bad;
    EXPECT_EQ(error_of(bad, 0), "--device: '" + bad + "' is not a device; give cpu, cuda or cuda:N") << bad;
  }
  try {
    parse_device("gpu", "--eval-device", 1);
    ADD_FAILURE() << "gpu was taken";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--eval-device: 'gpu'", 0), 0u) << e.what();
  }
}

TEST(ParseDevice, CudaWithoutCudaSaysSo) {
  EXPECT_EQ(error_of("cuda", 0), "--device cuda: CUDA is not available on this machine; use --device cpu");
  EXPECT_EQ(error_of("cuda:0", 0), "--device cuda:0: CUDA is not available on this machine; use --device cpu");
  EXPECT_EQ(error_of("cuda:2", 2),
            "--device cuda:2: CUDA device 2 is not available (this machine has 2); give cuda or cuda:0 to cuda:1");
  EXPECT_EQ(error_of("cuda:1", 2), "");
}

TEST(ParseDevice, DefaultsToThisMachinesDevices) {
  EXPECT_EQ(parse_device("cpu"), torch::Device(torch::kCPU));
  if (torch::cuda::is_available()) {
    EXPECT_EQ(parse_device("cuda:0"), torch::Device(torch::kCUDA, 0));
  } else {
    EXPECT_THROW(parse_device("cuda"), InvalidInput);
  }
}

}  // namespace
}  // namespace bareskin
