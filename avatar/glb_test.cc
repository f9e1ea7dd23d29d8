// The glTF writer against an independent Python reader.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "avatar/glb.h"
#include "avatar/glb_read.h"
#include "core/error.h"
#include "core/files.h"
#include "core/png.h"
#include "core/test_util.h"

namespace bareskin::texture {
namespace {
namespace fs = std::filesystem;

TEST(Glb, AnIndependentReaderFindsTheMeshAndMaterial) {
  // A 10 mm square whose vertex 0 has two UVs (a seam): 5 glTF vertices, 2 triangles.
  Mesh mesh;
  mesh.V.resize(4, 3);
  mesh.V << 0, 0, 0, 10, 0, 0, 10, 10, 0, 0, 10, 0;
  mesh.F.resize(2, 3);
  mesh.F << 0, 1, 2, 0, 2, 3;
  mesh.UV.resize(5, 2);
  mesh.UV << 0, 0, 1, 0, 1, 1, 0.25, 0.25, 0, 1;
  mesh.FUV.resize(2, 3);
  mesh.FUV << 0, 1, 2, 3, 2, 4;
  PbrMaps maps;
  maps.diffuse = Image(8, 8, 3, ColorSpace::Linear, 0.5f);
  maps.normal = Image(8, 8, 3, ColorSpace::Data, 0.5f);
  maps.roughness = Image(8, 8, 1, ColorSpace::Data, 0.4f);
  maps.specular = Image(8, 8, 1, ColorSpace::Data, 0.3f);
  const auto dir = testing::temp_dir();
  write_glb(dir + "/a.glb", mesh, maps);
  const std::string command = std::string("/usr/bin/python3 ") + BARESKIN_GLB_ORACLE + " " + dir + "/a.glb";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof(buffer), pipe)) out.append(buffer, n);
  ASSERT_EQ(pclose(pipe), 0) << "the oracle rejected the file: " << out;
  auto j = nlohmann::json::parse(out);
  EXPECT_EQ(j["vertices"], 5);
  EXPECT_EQ(j["triangles"], 2);
  EXPECT_NEAR(j["position_max"][0].get<double>(), 0.01, 1e-7);  // metres
  EXPECT_NEAR(j["position_max"][1].get<double>(), 0.01, 1e-7);
  EXPECT_NEAR(j["uv_min"][1].get<double>(), 0, 1e-7);  // v flipped to glTF's top-left origin
  EXPECT_NEAR(j["uv_max"][1].get<double>(), 1, 1e-7);
  EXPECT_EQ(j["base_color"], "diffuse");
  EXPECT_EQ(j["metallic_roughness"], "metallicRoughness");
  EXPECT_EQ(j["normal"], "normal");
  EXPECT_EQ(j["specular"], "specular");
  EXPECT_EQ(j["metallic_factor"], 0.0);
  // What a glTF reader samples: roughness from G and metallic from B of the grey roughness PNG (× metallicFactor 0),
  // the specular strength from the alpha channel, the base colour sRGB-encoded.
  EXPECT_NEAR(j["roughness_mean"].get<double>(), 0.4, 0.5 / 255);
  EXPECT_NEAR(j["metallic_mean"].get<double>(), 0, 1e-9);
  EXPECT_NEAR(j["specular_mean"].get<double>(), 0.3, 0.5 / 255);
  EXPECT_NEAR(j["base_color_mean"][0].get<double>(), linear_to_srgb(0.5f), 0.5 / 255);
  EXPECT_NEAR(j["normal_mean"][2].get<double>(), 0.5, 0.5 / 255);
  // The PNG-bytes form takes already encoded textures (the avatar folder's files: one encoding for both) and gives
  // the same file; it refuses bytes that are not PNG.
  const PbrPngs pngs{encode_png(to_srgb(maps.diffuse), 8), encode_png(maps.normal, 8), encode_png(maps.roughness, 8),
                     encode_png(specular_texture(maps.specular), 8)};
  EXPECT_EQ(glb_bytes(mesh, pngs), read_file(dir + "/a.glb"));
  // Our own reader (read_glb, fuzzed) agrees with the oracle, and refuses the damaged copies below.
  const GlbSummary summary = read_glb(read_file(dir + "/a.glb"), "a.glb");
  EXPECT_EQ(summary.vertices, 5);
  EXPECT_EQ(summary.triangles, 2);
  EXPECT_EQ(summary.images, (std::vector<std::string>{"diffuse", "normal", "metallicRoughness", "specular"}));
  EXPECT_EQ(summary.generator, "bareskin run");
  const std::string good = read_file(dir + "/a.glb");
  for (size_t cut : {size_t(0), size_t(19), good.size() / 2, good.size() - 1})
    EXPECT_THROW(read_glb(good.substr(0, cut), "cut.glb"), InvalidInput) << cut;
  std::string lying = good;  // the POSITION accessor claims 9 vertices in a view of 5
  const size_t at = lying.find("\"count\":5,");
  ASSERT_NE(at, std::string::npos);
  lying.replace(at, 10, "\"count\":9,");  // same length: the chunk sizes stay right
  EXPECT_THROW(read_glb(lying, "lying.glb"), InvalidInput);
  PbrPngs broken = pngs;
  broken.specular = "not a png";
  EXPECT_THROW(glb_bytes(mesh, broken), InvalidInput);
  // Corrupting the header's length is caught by the oracle (it is not a rubber stamp).
  std::string bytes = read_file(dir + "/a.glb");
  bytes[8] ^= 1;
  testing::write_text(dir + "/b.glb", bytes);
  EXPECT_NE(std::system((std::string("/usr/bin/python3 ") + BARESKIN_GLB_ORACLE + " " + dir + "/b.glb 2>/dev/null").c_str()),
            0);
  Mesh no_uv = mesh;
  no_uv.UV.resize(0, 2);
  no_uv.FUV.resize(0, 3);
  EXPECT_THROW(glb_bytes(no_uv, maps), InvalidInput);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace bareskin::texture
