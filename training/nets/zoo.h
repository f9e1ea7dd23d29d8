// The network zoo: every network by name with its paper-size defaults, built from JSON options (what a run's
// configuration holds and `bareskin train --list-models / --print-model NAME` prints), and the state dict as a
// safetensors file under the reference implementations' parameter names (torchvision, pix2pix, pix2pixHD, BasicSR),
// so Python users load it with load_state_dict as it is.
#pragma once
#include <torch/nn.h>

#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "training/nets/common.h"

namespace bareskin::nets {

struct ModelEntry {
  std::string name;         // resnet18, resnet50, unet256, patchgan, pix2pixhd_global, pix2pixhd_local,
                            // pix2pixhd_multiscale_d, msrresnet, srgan_d
  std::string summary;      // one line: what it is, its reference, its role in BareSkinNet
  nlohmann::json defaults;  // the options struct as JSON at the paper's sizes
  // Builds the network from options: the defaults overridden by the keys given (InvalidInput for an unknown key, a
  // value of the wrong type or out of range).
  std::function<std::shared_ptr<torch::nn::Module>(const nlohmann::json& options)> make;
};

const std::vector<ModelEntry>& model_zoo();
// InvalidInput listing the names when `name` is not in the zoo.
const ModelEntry& find_model(const std::string& name);

// Runs any network of the zoo on x: its forward; the multiscale discriminator's per-scale lists of layer outputs come
// flattened and concatenated (scale 0 first). For benchmarks, exports and shape printing; training code calls the
// typed modules. InternalError for a module that is not from the zoo.
torch::Tensor forward_output(torch::nn::Module& net, const torch::Tensor& x);

// Every parameter and buffer by its registered (= reference) name, detached, on the CPU.
std::map<std::string, torch::Tensor> state_dict(const torch::nn::Module& module);

// Writes state_dict(module) atomically as safetensors with `metadata` (e.g. {"model": name, "options": json}).
void export_state_dict(const torch::nn::Module& module, const std::string& path,
                       const std::map<std::string, std::string>& metadata = {});

// Copies a safetensors state dict into `module` (same names, shapes; dtypes converted). InvalidInput naming the file
// and the first missing, unexpected or mis-shaped tensor; IoError when it cannot be read.
void import_state_dict(torch::nn::Module& module, const std::string& path);

}  // namespace bareskin::nets
