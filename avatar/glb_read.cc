#include "avatar/glb_read.h"

#include <cstring>
#include <nlohmann/json.hpp>

#include "core/error.h"

namespace bareskin::texture {
namespace {

using json = nlohmann::json;
constexpr uint32_t kMagic = 0x46546C67, kJson = 0x4E4F534A, kBin = 0x004E4942;
constexpr const char* kHint = "the file is truncated or corrupt; write it again";

uint32_t u32(const std::string& b, size_t at) {
  uint32_t v;
  std::memcpy(&v, b.data() + at, 4);  // glTF is little-endian, as our hosts
  return v;
}

struct Reader {
  const std::string& source;
  [[noreturn]] void bad(const std::string& what) const { throw InvalidInput(source, what, kHint); }
  // j[key] as a non-negative integer below 2^53 (`fallback` when absent and fallback >= 0).
  uint64_t count(const json& j, const char* key, int64_t fallback = -1) const {
    if (!j.is_object()) bad(std::string("an entry holding '") + key + "' is not an object");
    const auto it = j.find(key);
    if (it == j.end()) {
      if (fallback < 0) bad(std::string("'") + key + "' is missing");
      return uint64_t(fallback);
    }
    if (!it->is_number_unsigned() || it->get<uint64_t>() > (uint64_t(1) << 53))
      bad(std::string("'") + key + "' is not a non-negative integer");
    return it->get<uint64_t>();
  }
  const json& item(const json& doc, const char* list, uint64_t index) const {
    const auto it = doc.find(list);
    if (it == doc.end() || !it->is_array() || index >= it->size())
      bad(std::string(list) + " " + std::to_string(index) + " does not exist");
    return (*it)[size_t(index)];
  }
};

size_t components(const std::string& type) {
  return type == "SCALAR" ? 1 : type == "VEC2" ? 2 : type == "VEC3" ? 3 : type == "VEC4" ? 4 : type == "MAT4" ? 16 : 0;
}
size_t component_size(uint64_t type) {
  return type == 5120 || type == 5121 ? 1 : type == 5122 || type == 5123 ? 2 : type == 5125 || type == 5126 ? 4 : 0;
}

// A bufferView's [offset, offset + length) inside the BIN chunk.
std::pair<uint64_t, uint64_t> view_range(const Reader& r, const json& doc, uint64_t index, uint64_t bin_size) {
  const json& view = r.item(doc, "bufferViews", index);
  if (r.count(view, "buffer") != 0) r.bad("bufferView " + std::to_string(index) + " names a buffer other than the BIN chunk");
  const uint64_t offset = r.count(view, "byteOffset", 0), length = r.count(view, "byteLength");
  if (offset > bin_size || length > bin_size - offset)
    r.bad("bufferView " + std::to_string(index) + " lies outside the " + std::to_string(bin_size) + "-byte BIN chunk");
  return {offset, length};
}

// An accessor checked against its view; returns its count and where its data starts in the BIN chunk.
struct Accessor {
  uint64_t count, start, stride, component_type;
};
Accessor accessor(const Reader& r, const json& doc, uint64_t index, uint64_t bin_size) {
  const json& a = r.item(doc, "accessors", index);
  const std::string name = "accessor " + std::to_string(index);
  const uint64_t type = r.count(a, "componentType");
  if (!a.contains("type") || !a["type"].is_string()) r.bad(name + " has no type");
  const size_t element = components(a["type"].get<std::string>()) * component_size(type);
  if (element == 0) r.bad(name + " has an unknown type or component type");
  const auto [view_offset, view_length] = view_range(r, doc, r.count(a, "bufferView"), bin_size);
  const json& view = r.item(doc, "bufferViews", r.count(a, "bufferView"));
  const uint64_t stride = r.count(view, "byteStride", 0) ? r.count(view, "byteStride") : element;
  const uint64_t offset = r.count(a, "byteOffset", 0), n = r.count(a, "count");
  if (stride < element) r.bad(name + " has a byteStride below its element size");
  const bool fits = n == 0 || (offset <= view_length && (n - 1) <= (view_length - offset) / stride &&
                               (n - 1) * stride + element <= view_length - offset);
  if (!fits) r.bad(name + " (" + std::to_string(n) + " elements) overruns its bufferView");
  return {n, view_offset + offset, stride, type};
}

}  // namespace

GlbSummary read_glb(const std::string& bytes, const std::string& source) {
  const Reader r{source};
  if (bytes.size() < 20 || u32(bytes, 0) != kMagic) r.bad("is not a binary glTF (.glb) file");
  if (u32(bytes, 4) != 2) r.bad("glTF version " + std::to_string(u32(bytes, 4)) + " is not 2");
  if (u32(bytes, 8) != bytes.size())
    r.bad("the header says " + std::to_string(u32(bytes, 8)) + " bytes, the file has " + std::to_string(bytes.size()));
  const uint64_t json_length = u32(bytes, 12);
  if (u32(bytes, 16) != kJson || json_length > bytes.size() - 20) r.bad("the first chunk is not a JSON chunk inside the file");
  const json doc = json::parse(bytes.begin() + 20, bytes.begin() + 20 + std::ptrdiff_t(json_length), nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) r.bad("the JSON chunk is not a JSON object");
  uint64_t bin_start = 20 + json_length, bin_size = 0;
  if (bin_start < bytes.size()) {
    if (bytes.size() - bin_start < 8 || u32(bytes, bin_start + 4) != kBin) r.bad("the second chunk is not a BIN chunk");
    bin_size = u32(bytes, bin_start);
    bin_start += 8;
    if (bin_size > bytes.size() - bin_start) r.bad("the BIN chunk overruns the file");
  }
  GlbSummary s;
  try {
    if (doc.contains("asset") && doc["asset"].is_object() && doc["asset"].value("generator", json()).is_string())
      s.generator = doc["asset"]["generator"].get<std::string>();
    if (doc.contains("bufferViews") && doc["bufferViews"].is_array())
      for (uint64_t v = 0; v < doc["bufferViews"].size(); ++v) view_range(r, doc, v, bin_size);
    if (doc.contains("accessors") && doc["accessors"].is_array())
      for (uint64_t a = 0; a < doc["accessors"].size(); ++a) accessor(r, doc, a, bin_size);
    if (doc.contains("images") && doc["images"].is_array())
      for (const json& image : doc["images"]) {
        view_range(r, doc, r.count(image, "bufferView"), bin_size);
        s.images.push_back(image.value("name", json("")).is_string() ? image.value("name", std::string()) : "");
      }
    const json& mesh = r.item(doc, "meshes", 0);
    if (!mesh.is_object() || !mesh.contains("primitives")) r.bad("mesh 0 has no primitives");
    const json& primitive = r.item(mesh, "primitives", 0);
    if (!primitive.is_object() || !primitive.contains("attributes") || !primitive["attributes"].is_object())
      r.bad("mesh 0's primitive has no attributes");
    const Accessor position = accessor(r, doc, r.count(primitive["attributes"], "POSITION"), bin_size);
    s.vertices = int64_t(position.count);
    if (primitive.contains("indices")) {
      const uint64_t which = r.count(primitive, "indices");
      const Accessor index = accessor(r, doc, which, bin_size);
      const json& spec = r.item(doc, "accessors", which);
      if (spec["type"] != "SCALAR" || (index.component_type != 5121 && index.component_type != 5123 &&
                                       index.component_type != 5125))
        r.bad("the indices are not unsigned integer scalars");
      if (index.count % 3) r.bad("the index count " + std::to_string(index.count) + " is not a multiple of 3");
      const size_t size = component_size(index.component_type);
      for (uint64_t k = 0; k < index.count; ++k) {
        uint32_t v = 0;
        std::memcpy(&v, bytes.data() + bin_start + index.start + k * index.stride, size);
        if (v >= position.count) r.bad("index " + std::to_string(k) + " names vertex " + std::to_string(v) + " of " +
                                       std::to_string(position.count));
      }
      s.triangles = int64_t(index.count / 3);
    } else {
      s.triangles = int64_t(position.count / 3);
    }
  } catch (const json::exception& e) {
    r.bad(std::string("malformed glTF JSON (") + e.what() + ")");
  }
  return s;
}

}  // namespace bareskin::texture
