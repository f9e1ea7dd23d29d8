// TensorFlow.js manifests decoded without Torch: every storage kind to its values, and hostile manifests refused
// (paths leaving the folder, shapes larger than the weights or than memory, duplicates).
#include "detect/tfjs_manifest.h"

#include <gtest/gtest.h>

#include <cstring>
#include <functional>

#include "core/error.h"

namespace bareskin::detect {
namespace {

template <typename T>
std::string bytes_of(std::initializer_list<T> values) {
  std::string b;
  for (T v : values) b.append(reinterpret_cast<const char*>(&v), sizeof v);
  return b;
}

std::vector<TfjsTensor> decode(const std::string& manifest, const std::string& bin) {
  return decode_tfjs_weights(manifest, "m.json", [&](const std::string& path) {
    if (path != "w.bin") throw IoError(path, "no such file", "");
    return bin;
  });
}

std::string message(const std::string& manifest, const std::string& bin) {
  try {
    decode(manifest, bin);
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

TEST(TfjsManifest, EveryStorageKindDecodes) {
  const std::string manifest = R"([{"paths": ["w.bin"], "weights": [
    {"name": "f32", "shape": [2, 2], "dtype": "float32"},
    {"name": "i32", "shape": [3], "dtype": "int32"},
    {"name": "q8", "shape": [2], "dtype": "float32", "quantization": {"dtype": "uint8", "scale": 0.5, "min": -1}},
    {"name": "q16", "shape": [2], "dtype": "float32", "quantization": {"dtype": "uint16", "scale": 0.25, "min": 1}},
    {"name": "h16", "shape": [3], "dtype": "float32", "quantization": {"dtype": "float16"}},
    {"name": "scalar", "shape": [], "dtype": "float32"}]}])";
  const std::string bin = bytes_of<float>({1, -2, 3.5f, 0}) + bytes_of<int32_t>({1, -7, 1 << 30}) +
                          std::string{0, char(255)} + bytes_of<uint16_t>({0, 65535}) +
                          bytes_of<uint16_t>({0x3e00, 0xb400, 0x0001}) + bytes_of<float>({42});
  const auto t = decode(manifest, bin);
  ASSERT_EQ(t.size(), 6u);
  EXPECT_EQ(t[0].values, (std::vector<float>{1, -2, 3.5f, 0}));
  EXPECT_EQ(t[0].shape, (std::vector<int64_t>{2, 2}));
  EXPECT_TRUE(t[1].is_int);
  EXPECT_EQ(t[1].ints, (std::vector<int32_t>{1, -7, 1 << 30}));
  EXPECT_EQ(t[2].values, (std::vector<float>{-1, 126.5f}));
  EXPECT_EQ(t[3].values, (std::vector<float>{1, 16384.75f}));
  EXPECT_EQ(t[4].values, (std::vector<float>{1.5f, -0.25f, 5.9604645e-8f}));  // the last: the smallest subnormal
  EXPECT_EQ(t[5].values, (std::vector<float>{42}));
}

TEST(TfjsManifest, HostileManifestsAreRefused) {
  const auto one = [](const std::string& path, const std::string& shape) {
    return R"([{"paths": [")" + path + R"("], "weights": [{"name": "w", "shape": )" + shape + R"(, "dtype": "float32"}]}])";
  };
  const std::string four = bytes_of<float>({1, 2, 3, 4});
  EXPECT_EQ(message(one("w.bin", "[4]"), four), "");
  EXPECT_NE(message(one("../w.bin", "[4]"), four).find("weight file path '../w.bin' leaves the manifest's folder"),
            std::string::npos);
  EXPECT_NE(message(one("/etc/passwd", "[4]"), four).find("'/etc/passwd' leaves"), std::string::npos);
  EXPECT_NE(message(one("a/../../w.bin", "[4]"), four).find("leaves"), std::string::npos);
  // Shapes whose product overflows 64 bits, or needs more than the file holds, are refused without allocating.
  EXPECT_NE(message(one("w.bin", "[4294967296, 4294967296, 4294967296]"), four).find("needs more"), std::string::npos);
  EXPECT_NE(message(one("w.bin", "[5]"), four).find("needs more"), std::string::npos);
  EXPECT_NE(message(one("w.bin", "[-1]"), four).find("negative"), std::string::npos);
  EXPECT_NE(message(one("w.bin", "[3]"), four).find("4 bytes more"), std::string::npos);
  EXPECT_NE(message(one("w.bin", "\"x\""), four).find("malformed"), std::string::npos);
  EXPECT_NE(message("{", four).find("not a TensorFlow.js weight manifest"), std::string::npos);
  const std::string twice = R"([{"paths": ["w.bin"], "weights": [{"name": "w", "shape": [2], "dtype": "float32"},
                                                              {"name": "w", "shape": [2], "dtype": "float32"}]}])";
  EXPECT_NE(message(twice, four).find("appears twice"), std::string::npos);
}

}  // namespace
}  // namespace bareskin::detect
