#include "detect/tfjs_weights.h"

#include <torch/torch.h>

#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"

namespace bareskin::detect {
namespace {

struct Storage {
  torch::ScalarType type;  // how the bytes are stored
  bool quantised;          // value = q * scale + min
};

Storage storage_of(const nlohmann::json& entry, const std::string& manifest) {
  const std::string name = entry.at("name").get<std::string>();
  const std::string dtype = entry.at("dtype").get<std::string>();
  if (dtype != "float32" && dtype != "int32")
    throw InvalidInput(manifest, "tensor '" + name + "' has dtype '" + dtype + "'",
                       "only float32 and int32 tensors are supported");
  if (!entry.contains("quantization")) return {dtype == "float32" ? torch::kFloat : torch::kInt, false};
  const std::string q = entry["quantization"].at("dtype").get<std::string>();
  if (q == "uint8") return {torch::kUInt8, true};
  if (q == "uint16") return {torch::kInt32, true};  // widened below: LibTorch 1.13 has no uint16
  if (q == "float16") return {torch::kHalf, false};
  throw InvalidInput(manifest, "tensor '" + name + "' is quantised as '" + q + "'",
                     "supported quantisations are uint8, uint16 and float16");
}

}  // namespace

std::map<std::string, torch::Tensor> read_tfjs_weights(const std::string& manifest) {
  nlohmann::json groups;
  try {
    groups = nlohmann::json::parse(read_file(manifest));
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(manifest, std::string("not a TensorFlow.js weight manifest (") + e.what() + ")",
                       "pass the *-weights_manifest.json that came with the weights ('make deps' fetches them)");
  }
  const std::filesystem::path folder = std::filesystem::path(manifest).parent_path();
  std::map<std::string, torch::Tensor> tensors;
  try {
    if (!groups.is_array()) throw InvalidInput(manifest, "the manifest is not a list of weight groups", "check the file");
    for (const auto& group : groups) {
      std::string bytes;
      for (const auto& path : group.at("paths")) bytes += read_file((folder / path.get<std::string>()).string());
      size_t offset = 0;
      for (const auto& entry : group.at("weights")) {
        const std::string name = entry.at("name").get<std::string>();
        const std::vector<int64_t> shape = entry.at("shape").get<std::vector<int64_t>>();
        int64_t count = 1;
        for (int64_t d : shape) {
          if (d < 0) throw InvalidInput(manifest, "tensor '" + name + "' has a negative dimension", "check the file");
          count *= d;
        }
        const Storage storage = storage_of(entry, manifest);
        const bool is_u16 = storage.quantised && entry["quantization"].at("dtype") == "uint16";
        const size_t element = is_u16 ? 2 : torch::elementSize(storage.type);
        const size_t size = size_t(count) * element;
        if (offset + size > bytes.size())
          throw InvalidInput(manifest, "its weight files hold " + std::to_string(bytes.size()) + " bytes but tensor '" +
                                           name + "' needs bytes up to " + std::to_string(offset + size),
                             "the .bin file is truncated or belongs to another model; run 'make deps' again");
        torch::Tensor t;
        if (is_u16) {
          std::vector<uint16_t> q(static_cast<size_t>(count));
          std::memcpy(q.data(), bytes.data() + offset, size);
          t = torch::tensor(std::vector<int32_t>(q.begin(), q.end()), torch::kInt).to(torch::kFloat);
        } else {
          t = torch::from_blob(bytes.data() + offset, {count}, storage.type).clone();
        }
        offset += size;
        if (storage.quantised) {
          const auto& q = entry["quantization"];
          t = t.to(torch::kFloat) * q.at("scale").get<double>() + q.at("min").get<double>();
        }
        t = t.to(entry.at("dtype") == "int32" ? torch::kInt : torch::kFloat).reshape(shape);
        if (!tensors.emplace(name, t).second)
          throw InvalidInput(manifest, "tensor '" + name + "' appears twice", "check the file");
      }
      if (offset != bytes.size())
        throw InvalidInput(manifest, "its weight files hold " + std::to_string(bytes.size() - offset) +
                                         " bytes more than the manifest lists",
                           "the .bin file belongs to another model; run 'make deps' again");
    }
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(manifest, std::string("malformed weight manifest (") + e.what() + ")", "check the file");
  }
  return tensors;
}

}  // namespace bareskin::detect
