#include "avatar/glb.h"

#include <nlohmann/json.hpp>

#include <cstring>
#include <future>
#include <map>
#include <vector>

#include "core/error.h"
#include "core/files.h"
#include "core/png.h"

namespace bareskin::texture {
namespace {

constexpr uint32_t kMagic = 0x46546C67, kJsonChunk = 0x4E4F534A, kBinChunk = 0x004E4942;
constexpr int kFloat = 5126, kUnsignedInt = 5125, kArrayBuffer = 34962, kElementArrayBuffer = 34963;

// The binary chunk and its bufferViews/accessors as they are appended.
struct Builder {
  std::string bin;
  nlohmann::json views = nlohmann::json::array(), accessors = nlohmann::json::array();

  int view(const void* data, size_t bytes, int target) {
    while (bin.size() % 4) bin.push_back('\0');
    nlohmann::json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
    if (target) v["target"] = target;
    bin.append(static_cast<const char*>(data), bytes);
    views.push_back(v);
    return int(views.size()) - 1;
  }
  int floats(const std::vector<float>& values, int components, const char* type, bool bounds) {
    const size_t count = values.size() / components;
    nlohmann::json a = {{"bufferView", view(values.data(), values.size() * 4, kArrayBuffer)},
                        {"componentType", kFloat},
                        {"count", count},
                        {"type", type}};
    if (bounds) {
      std::vector<float> lo(components, 1e30f), hi(components, -1e30f);
      for (size_t i = 0; i < count; ++i)
        for (int c = 0; c < components; ++c) {
          lo[c] = std::min(lo[c], values[i * components + c]);
          hi[c] = std::max(hi[c], values[i * components + c]);
        }
      a["min"] = lo;
      a["max"] = hi;
    }
    accessors.push_back(a);
    return int(accessors.size()) - 1;
  }
  int indices(const std::vector<uint32_t>& values) {
    accessors.push_back({{"bufferView", view(values.data(), values.size() * 4, kElementArrayBuffer)},
                         {"componentType", kUnsignedInt},
                         {"count", values.size()},
                         {"type", "SCALAR"}});
    return int(accessors.size()) - 1;
  }
};

void require_map(const Image& image, const char* name, int channels) {
  if (image.empty() || image.channels < channels)
    throw InvalidInput(std::string("avatar ") + name + " map", "is missing or has too few channels",
                       "pass all four maps (diffuse, normal, roughness, specular)");
}

void require_png(const std::string& bytes, const char* name) {
  static const char kSignature[] = "\x89PNG\r\n\x1a\n";
  if (bytes.size() < 8 || bytes.compare(0, 8, kSignature, 8) != 0)
    throw InvalidInput(std::string("avatar ") + name + " texture", "is not PNG data",
                       "pass the four maps' PNG bytes (core/png.h encode_png)");
}

Image first_channels(const Image& image, int channels) {
  if (image.channels == channels) return image;
  Image out(image.width, image.height, channels, image.color_space);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < channels; ++c) out.at(x, y, c) = image.at(x, y, c);
  return out;
}

}  // namespace

Image specular_texture(const Image& specular) {
  Image out(specular.width, specular.height, 2, ColorSpace::Data, 1.f);
  for (int y = 0; y < specular.height; ++y)
    for (int x = 0; x < specular.width; ++x) out.at(x, y, 1) = specular.at(x, y, 0);
  return out;
}

std::string glb_bytes(const Mesh& mesh, const PbrMaps& maps) {
  require_map(maps.diffuse, "diffuse", 3);
  require_map(maps.normal, "normal", 3);
  require_map(maps.roughness, "roughness", 1);
  require_map(maps.specular, "specular", 1);
  // The four textures are encoded concurrently (at 4K the PNG encoder is most of the file's cost).
  auto diffuse = std::async(std::launch::async, [&maps] {
    return encode_png(first_channels(maps.diffuse.color_space == ColorSpace::sRGB ? maps.diffuse : to_srgb(maps.diffuse), 3), 8);
  });
  auto normal = std::async(std::launch::async, [&maps] { return encode_png(first_channels(maps.normal, 3), 8); });
  auto roughness = std::async(std::launch::async, [&maps] { return encode_png(first_channels(maps.roughness, 1), 8); });
  const std::string specular = encode_png(specular_texture(maps.specular), 8);
  return glb_bytes(mesh, PbrPngs{diffuse.get(), normal.get(), roughness.get(), specular});
}

std::string glb_bytes(const Mesh& mesh, const PbrPngs& textures) {
  validate(mesh, "avatar mesh");
  if (!mesh.has_uv()) throw InvalidInput("avatar mesh", "has no texture coordinates", "use the model's template UV");
  require_png(textures.diffuse, "diffuse");
  require_png(textures.normal, "normal");
  require_png(textures.metallic_roughness, "metallicRoughness");
  require_png(textures.specular, "specular");

  // glTF attributes are per vertex: one vertex per distinct (position, UV) corner pair, so UV seams split vertices.
  Mesh with_normals;
  if (!mesh.has_normals()) {
    with_normals = mesh;
    with_normals.N = vertex_normals(mesh.V, mesh.F);
  }
  const Mesh& m = mesh.has_normals() ? mesh : with_normals;
  const Eigen::MatrixX4d tangents = uv_tangents(m);
  // The glTF vertex of each (position, UV) pair, numbered as first met: found through the UV index (a UV index
  // nearly always belongs to one position), the rare UV index shared by several positions through a map.
  constexpr uint32_t kNone = ~0u;
  std::vector<uint32_t> by_uv(size_t(m.UV.rows()), kNone);
  std::vector<int> vertex_of;  // the position of each glTF vertex
  std::map<std::pair<int, int>, uint32_t> shared_uv;
  const auto corner = [&](int v, int t) -> std::pair<uint32_t, bool> {
    const uint32_t next = uint32_t(vertex_of.size());
    uint32_t& first = by_uv[size_t(t)];
    if (first == kNone) return {first = next, true};
    if (vertex_of[first] == v) return {first, false};
    auto [it, inserted] = shared_uv.emplace(std::make_pair(v, t), next);
    return {it->second, inserted};
  };
  std::vector<float> positions, normals, tangent, uvs;
  std::vector<uint32_t> index;
  for (int f = 0; f < m.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      const int v = m.F(f, k), t = m.FUV(f, k);
      const auto [id, inserted] = corner(v, t);
      if (inserted) {
        vertex_of.push_back(v);
        for (int c = 0; c < 3; ++c) positions.push_back(float(m.V(v, c) * 1e-3));
        for (int c = 0; c < 3; ++c) normals.push_back(float(m.N(v, c)));
        Eigen::Vector4d tg = tangents.row(t);
        if (tg.head<3>().squaredNorm() < 1e-12) tg = Eigen::Vector4d(1, 0, 0, 1);  // degenerate faces only
        for (int c = 0; c < 4; ++c) tangent.push_back(float(tg[c]));
        uvs.push_back(float(m.UV(t, 0)));
        uvs.push_back(float(1 - m.UV(t, 1)));
      }
      index.push_back(id);
    }

  Builder b;
  nlohmann::json attributes = {{"POSITION", b.floats(positions, 3, "VEC3", true)},
                               {"NORMAL", b.floats(normals, 3, "VEC3", false)},
                               {"TANGENT", b.floats(tangent, 4, "VEC4", false)},
                               {"TEXCOORD_0", b.floats(uvs, 2, "VEC2", false)}};
  const int indices = b.indices(index);
  nlohmann::json images = nlohmann::json::array(), texture_list = nlohmann::json::array();
  auto texture = [&](const std::string& png, const char* name) {
    images.push_back({{"name", name}, {"mimeType", "image/png"}, {"bufferView", b.view(png.data(), png.size(), 0)}});
    texture_list.push_back({{"sampler", 0}, {"source", int(images.size()) - 1}});
    return int(texture_list.size()) - 1;
  };
  const int base = texture(textures.diffuse, "diffuse");
  const int normal = texture(textures.normal, "normal");
  const int mr = texture(textures.metallic_roughness, "metallicRoughness");
  const int spec = texture(textures.specular, "specular");
  while (b.bin.size() % 4) b.bin.push_back('\0');

  nlohmann::json gltf = {
      {"asset", {{"version", "2.0"}, {"generator", "bareskin run"}}},
      {"extensionsUsed", {"KHR_materials_specular"}},
      {"scene", 0},
      {"scenes", {{{"nodes", {0}}}}},
      {"nodes", {{{"mesh", 0}, {"name", "face"}}}},
      {"meshes", {{{"name", "face"}, {"primitives", {{{"attributes", attributes}, {"indices", indices},
                                                        {"material", 0}, {"mode", 4}}}}}}},
      {"materials",
       {{{"name", "skin"},
         {"pbrMetallicRoughness",
          {{"baseColorTexture", {{"index", base}}},
           {"metallicRoughnessTexture", {{"index", mr}}},
           {"metallicFactor", 0.0},
           {"roughnessFactor", 1.0}}},
         {"normalTexture", {{"index", normal}}},
         {"extensions",
          {{"KHR_materials_specular",
            {{"specularFactor", 1.0}, {"specularTexture", {{"index", spec}}}, {"specularColorFactor", {1.0, 1.0, 1.0}}}}}}}}},
      {"samplers", {{{"magFilter", 9729}, {"minFilter", 9987}, {"wrapS", 33071}, {"wrapT", 33071}}}},
      {"images", images},
      {"textures", texture_list},
      {"accessors", b.accessors},
      {"bufferViews", b.views},
      {"buffers", {{{"byteLength", b.bin.size()}}}}};
  std::string json = gltf.dump();
  while (json.size() % 4) json.push_back(' ');

  std::string out;
  auto u32 = [&out](uint32_t x) { out.append(reinterpret_cast<const char*>(&x), 4); };  // little-endian hosts
  u32(kMagic);
  u32(2);
  u32(uint32_t(12 + 8 + json.size() + 8 + b.bin.size()));
  u32(uint32_t(json.size()));
  u32(kJsonChunk);
  out += json;
  u32(uint32_t(b.bin.size()));
  u32(kBinChunk);
  out += b.bin;
  return out;
}

void write_glb(const std::string& path, const Mesh& mesh, const PbrPngs& textures) {
  write_file_atomic(path, glb_bytes(mesh, textures));
}

void write_glb(const std::string& path, const Mesh& mesh, const PbrMaps& maps) {
  write_file_atomic(path, glb_bytes(mesh, maps));
}

}  // namespace bareskin::texture
