#include "training/tensor_io.h"

#include <torch/torch.h>

#include <cstring>

#include "core/error.h"

namespace bareskin {
namespace {

struct DTypePair {
  DType ours;
  torch::ScalarType theirs;
};
const DTypePair kPairs[] = {
    {DType::BOOL, torch::kBool}, {DType::U8, torch::kUInt8},   {DType::I8, torch::kInt8},
    {DType::I16, torch::kInt16}, {DType::F16, torch::kFloat16}, {DType::BF16, torch::kBFloat16},
    {DType::I32, torch::kInt32}, {DType::F32, torch::kFloat32}, {DType::I64, torch::kInt64},
    {DType::F64, torch::kFloat64},
};

}  // namespace

torch::Tensor to_tensor(const TensorView& view, const std::string& source) {
  for (const auto& p : kPairs) {
    if (p.ours == view.dtype) {
      torch::Tensor t = torch::empty(view.shape, torch::TensorOptions().dtype(p.theirs));
      if (view.nbytes) std::memcpy(t.data_ptr(), view.data, view.nbytes);
      return t;
    }
  }
  throw InvalidInput(source, std::string("dtype ") + dtype_name(view.dtype) + " has no LibTorch equivalent",
                     "convert the tensor to a signed or float type");
}

void add_tensor(SafeTensorsWriter& writer, const std::string& name, const torch::Tensor& tensor) {
  const torch::Tensor t = tensor.detach().to(torch::kCPU).contiguous();
  for (const auto& p : kPairs) {
    if (p.theirs == t.scalar_type()) {
      writer.add(name, p.ours, t.sizes().vec(), t.data_ptr(), size_t(t.numel()) * t.element_size());
      return;
    }
  }
  throw InvalidInput("", "tensor '" + name + "' has a dtype safetensors cannot hold", "");
}

std::map<std::string, torch::Tensor> load_tensors(const std::string& path) {
  const SafeTensors file = SafeTensors::open(path);
  std::map<std::string, torch::Tensor> out;
  for (const std::string& name : file.names()) out[name] = to_tensor(file.tensor(name), path);
  return out;
}

void save_tensors(const std::string& path, const std::map<std::string, torch::Tensor>& tensors,
                  const std::map<std::string, std::string>& metadata) {
  SafeTensorsWriter writer;
  for (const auto& [name, t] : tensors) add_tensor(writer, name, t);
  for (const auto& [k, v] : metadata) writer.set_metadata(k, v);
  writer.write(path);
}

}  // namespace bareskin
