#include "detect/tfjs_manifest.h"

#include <cmath>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>

#include "core/error.h"
#include "core/files.h"
#include "core/memory_limit.h"

namespace bareskin::detect {
namespace {

enum class Stored { Float32, Int32, UInt8, UInt16, Float16 };

struct Storage {
  Stored type;
  bool quantised;  // value = q * scale + min
  size_t element() const {
    return type == Stored::UInt8 ? 1 : type == Stored::UInt16 || type == Stored::Float16 ? 2 : 4;
  }
};

Storage storage_of(const nlohmann::json& entry, const std::string& name, const std::string& manifest) {
  const std::string dtype = entry.at("dtype").get<std::string>();
  if (dtype != "float32" && dtype != "int32")
    throw InvalidInput(manifest, "tensor '" + name + "' has dtype '" + dtype + "'",
                       "only float32 and int32 tensors are supported");
  if (!entry.contains("quantization")) return {dtype == "float32" ? Stored::Float32 : Stored::Int32, false};
  const std::string q = entry["quantization"].at("dtype").get<std::string>();
  if (q == "uint8") return {Stored::UInt8, true};
  if (q == "uint16") return {Stored::UInt16, true};
  if (q == "float16") return {Stored::Float16, false};
  throw InvalidInput(manifest, "tensor '" + name + "' is quantised as '" + q + "'",
                     "supported quantisations are uint8, uint16 and float16");
}

float half_to_float(uint16_t h) {
  const int exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
  const float sign = (h & 0x8000) ? -1.f : 1.f;
  if (exponent == 0) return sign * std::ldexp(float(mantissa), -24);
  if (exponent == 31) return mantissa ? std::nanf("") : sign * INFINITY;
  return sign * std::ldexp(float(mantissa | 0x400), exponent - 25);
}

template <typename T>
T load(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// One tensor's elements from `bytes` at `p`, as float (for float32 tensors, and int32 ones stored quantised).
float element(const Storage& s, const char* p, float scale, float min) {
  switch (s.type) {
    case Stored::Float32: return load<float>(p);
    case Stored::Int32: return float(load<int32_t>(p));
    case Stored::Float16: return half_to_float(load<uint16_t>(p));
    case Stored::UInt8: return float(uint8_t(*p)) * scale + min;
    case Stored::UInt16: return float(load<uint16_t>(p)) * scale + min;
  }
  return 0;
}

// A shard path stays inside the manifest's folder: relative, no '..' component.
void check_shard_path(const std::string& path, const std::string& manifest) {
  const std::filesystem::path p(path);
  bool up = false;
  for (const auto& part : p) up = up || part == "..";
  if (path.empty() || p.is_absolute() || up)
    throw InvalidInput(manifest, "weight file path '" + path + "' leaves the manifest's folder",
                       "the manifest is corrupt or hostile; use the one that came with the weights");
}

TfjsTensor decode_tensor(const nlohmann::json& entry, const std::string& bytes, size_t& offset,
                         const std::string& manifest) {
  TfjsTensor t;
  t.name = entry.at("name").get<std::string>();
  t.shape = entry.at("shape").get<std::vector<int64_t>>();
  const Storage storage = storage_of(entry, t.name, manifest);
  const size_t available = bytes.size() - offset;
  size_t count = 1;
  for (int64_t d : t.shape) {
    if (d < 0) throw InvalidInput(manifest, "tensor '" + t.name + "' has a negative dimension", "check the file");
    if (d > 0 && count > available / size_t(d)) count = available + 1;  // more than the shards hold: refused below
    else count *= size_t(d);
  }
  if (count > available / storage.element())
    throw InvalidInput(manifest, "its weight files hold " + std::to_string(bytes.size()) + " bytes but tensor '" +
                                     t.name + "' needs more from byte " + std::to_string(offset),
                       "the .bin file is truncated or belongs to another model; run 'make deps' again");
  float scale = 1, min = 0;
  if (storage.quantised) {
    const auto& q = entry["quantization"];
    scale = float(q.at("scale").get<double>()), min = float(q.at("min").get<double>());
  }
  t.is_int = entry.at("dtype") == "int32";
  const char* p = bytes.data() + offset;
  if (t.is_int && storage.type == Stored::Int32) {
    t.ints.resize(count);
    if (count) std::memcpy(t.ints.data(), p, count * 4);
  } else {
    std::vector<float> v(count);
    for (size_t i = 0; i < count; ++i) v[i] = element(storage, p + i * storage.element(), scale, min);
    if (t.is_int) {
      t.ints.resize(count);
      for (size_t i = 0; i < count; ++i)
        t.ints[i] = std::isfinite(v[i]) && std::fabs(v[i]) < 2.1e9f ? int32_t(v[i]) : 0;
    } else {
      t.values = std::move(v);
    }
  }
  offset += count * storage.element();
  return t;
}

}  // namespace

std::vector<TfjsTensor> decode_tfjs_weights(const std::string& manifest_text, const std::string& manifest,
                                            const TfjsShardSource& read_shard) {
  const nlohmann::json groups = nlohmann::json::parse(manifest_text, nullptr, false);
  if (groups.is_discarded())
    throw InvalidInput(manifest, "not a TensorFlow.js weight manifest (not JSON)",
                       "pass the *-weights_manifest.json that came with the weights ('make deps' fetches them)");
  if (!groups.is_array()) throw InvalidInput(manifest, "the manifest is not a list of weight groups", "check the file");
  std::vector<TfjsTensor> tensors;
  std::set<std::string> names;
  try {
    for (const auto& group : groups) {
      std::string bytes;
      for (const auto& path : group.at("paths")) {
        check_shard_path(path.get<std::string>(), manifest);
        bytes += read_shard(path.get<std::string>());
        check_memory(manifest, double(bytes.size()), "its weight files");
      }
      size_t offset = 0;
      for (const auto& entry : group.at("weights")) {
        tensors.push_back(decode_tensor(entry, bytes, offset, manifest));
        if (!names.insert(tensors.back().name).second)
          throw InvalidInput(manifest, "tensor '" + tensors.back().name + "' appears twice", "check the file");
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

std::vector<TfjsTensor> read_tfjs_tensors(const std::string& manifest) {
  const std::filesystem::path folder = std::filesystem::path(manifest).parent_path();
  return decode_tfjs_weights(read_file(manifest), manifest,
                             [&](const std::string& path) { return read_file((folder / path).string()); });
}

}  // namespace bareskin::detect
