// Writes networks of the zoo for the Python oracle (tests/python/torchvision_oracle.py): per case
// <case>.safetensors (the state dict as export_state_dict writes it, metadata: model, options) and
// <case>_io.safetensors (a fixed input and our output on it, eval mode). Batch norms first see two training batches so
// that their running statistics are not the trivial 0/1.
//   nets_oracle_export OUT_DIR
#include <torch/torch.h>

#include <cstdio>
#include <string>

#include "training/nets/zoo.h"
#include "training/tensor_io.h"

using namespace bareskin;
using namespace bareskin::nets;

namespace {

void export_case(const std::string& dir, const std::string& name, const std::string& model,
                 const nlohmann::json& options, std::vector<int64_t> input_shape) {
  torch::manual_seed(7);
  const auto net = find_model(model).make(options);
  net->train();
  for (int i = 0; i < 2; ++i) forward_output(*net, torch::randn(input_shape) * 2 + 0.5);
  net->eval();
  const torch::Tensor x = torch::randn(input_shape);
  torch::Tensor y;
  {
    torch::NoGradGuard no_grad;
    y = forward_output(*net, x);
  }
  export_state_dict(*net, dir + "/" + name + ".safetensors", {{"model", model}, {"options", options.dump()}});
  save_tensors(dir + "/" + name + "_io.safetensors", {{"input", x}, {"output", y}});
  std::printf("%s: %s %s, %lld parameters\n", name.c_str(), model.c_str(), options.dump().c_str(),
              static_cast<long long>(parameter_count(*net)));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: nets_oracle_export OUT_DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  using J = nlohmann::json;
  export_case(dir, "resnet18", "resnet18", J::object(), {2, 3, 64, 64});
  export_case(dir, "resnet50", "resnet50", J::object(), {2, 3, 64, 64});
  export_case(dir, "resnet34_headless", "resnet18", J{{"depth", 34}, {"num_classes", 0}}, {2, 3, 64, 64});
  export_case(dir, "resnet18_width8", "resnet18", J{{"width", 8}, {"num_classes", 16}}, {2, 3, 64, 64});
  export_case(dir, "unet_ngf8", "unet256", J{{"ngf", 8}}, {2, 3, 256, 256});
  export_case(dir, "unet_instance", "unet256",
              J{{"ngf", 8}, {"num_downs", 6}, {"norm", "instance"}, {"in_channels", 4}}, {2, 4, 64, 64});
  export_case(dir, "patchgan", "patchgan", J{{"ndf", 16}}, {2, 6, 64, 64});
  export_case(dir, "pix2pixhd_global", "pix2pixhd_global", J{{"ngf", 8}, {"n_downsampling", 3}, {"n_blocks", 2}},
              {2, 3, 32, 32});
  export_case(dir, "pix2pixhd_local", "pix2pixhd_local",
              J{{"ngf", 4}, {"n_downsample_global", 2}, {"n_blocks_global", 2}, {"n_blocks_local", 1}}, {2, 3, 32, 32});
  export_case(dir, "pix2pixhd_multiscale_d", "pix2pixhd_multiscale_d", J{{"ndf", 8}, {"num_D", 3}}, {2, 6, 64, 64});
  export_case(dir, "msrresnet", "msrresnet", J{{"num_feat", 16}, {"num_block", 3}}, {2, 3, 12, 12});
  export_case(dir, "srgan_d", "srgan_d", J{{"num_feat", 8}}, {2, 3, 128, 128});
  return 0;
}
