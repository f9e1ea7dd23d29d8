#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/safetensors.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

uint64_t header_length(const std::string& bytes) {
  uint64_t n;
  std::memcpy(&n, bytes.data(), 8);
  return n;
}

SafeTensorsWriter sample_writer() {
  SafeTensorsWriter w;
  w.add<float>("mean_shape", {2, 3}, {1, 2, 3, 4, 5, 6.5f});
  w.add<int32_t>("triangles", {1, 3}, {0, 1, 2});
  w.add<uint8_t>("mask", {3}, {1, 0, 255});
  w.add<double>("sigma", {}, {0.25});
  w.set_metadata("format_version", "1");
  w.set_metadata("units", "mm");
  return w;
}

// The byte layout, checked against the format's specification rather than our reader.
TEST(SafeTensors, ByteLayoutFollowsTheSpecification) {
  const std::string bytes = sample_writer().serialize();
  const uint64_t n = header_length(bytes);
  EXPECT_EQ((8 + n) % 8, 0u) << "data section is 8-byte aligned";
  const auto header = nlohmann::json::parse(bytes.substr(8, n));
  EXPECT_EQ(header["__metadata__"]["units"], "mm");
  EXPECT_EQ(header["mean_shape"]["dtype"], "F32");
  EXPECT_EQ(header["mean_shape"]["shape"], nlohmann::json({2, 3}));
  EXPECT_EQ(header["sigma"]["shape"], nlohmann::json::array());
  // Largest dtype first: F64 (8 bytes) at 0, then F32 at 8, I32 at 32, U8 last.
  EXPECT_EQ(header["sigma"]["data_offsets"], nlohmann::json({0, 8}));
  EXPECT_EQ(header["mean_shape"]["data_offsets"], nlohmann::json({8, 32}));
  EXPECT_EQ(header["triangles"]["data_offsets"], nlohmann::json({32, 44}));
  EXPECT_EQ(header["mask"]["data_offsets"], nlohmann::json({44, 47}));
  EXPECT_EQ(bytes.size(), 8 + n + 47);
  float third;
  std::memcpy(&third, bytes.data() + 8 + n + 8 + 5 * 4, 4);
  EXPECT_EQ(third, 6.5f) << "raw little-endian float32 at its offset";
}

TEST(SafeTensors, FileRoundTripThroughMmap) {
  const std::string path = testing::temp_dir() + "/m.safetensors";
  sample_writer().write(path);
  const SafeTensors st = SafeTensors::open(path);
  EXPECT_EQ(st.metadata().at("format_version"), "1");
  EXPECT_EQ(st.names(), (std::vector<std::string>{"sigma", "mean_shape", "triangles", "mask"}));
  EXPECT_EQ(st.tensor("mean_shape", DType::F32, {-1, 3}).to_vector<float>(), (std::vector<float>{1, 2, 3, 4, 5, 6.5f}));
  EXPECT_EQ(st.tensor("triangles").to_vector<int64_t>(), (std::vector<int64_t>{0, 1, 2}));
  EXPECT_EQ(st.tensor("mask").to_vector<float>(), (std::vector<float>{1, 0, 255}));
  EXPECT_EQ(st.tensor("sigma").numel(), 1);
  EXPECT_THROW(st.tensor("mean_shape", DType::F64, {2, 3}), InvalidInput);
  EXPECT_THROW(st.tensor("nope"), InvalidInput);
}

TEST(SafeTensors, HalfPrecisionDecodes) {
  SafeTensorsWriter w;
  const uint16_t halves[] = {0x3c00, 0xc000, 0x3555, 0x0001, 0x7bff};  // 1, -2, 0.333, smallest subnormal, 65504
  w.add("h", DType::F16, {5}, halves, sizeof halves);
  const std::vector<float> v = SafeTensors::parse(w.serialize(), "mem").tensor("h").to_vector<float>();
  EXPECT_EQ(v[0], 1.f);
  EXPECT_EQ(v[1], -2.f);
  EXPECT_NEAR(v[2], 0.33325f, 1e-5);
  EXPECT_FLOAT_EQ(v[3], 5.9604645e-8f);
  EXPECT_EQ(v[4], 65504.f);
}

TEST(SafeTensors, MalformedFilesAreRejected) {
  const std::string good = sample_writer().serialize();
  const uint64_t n = header_length(good);
  const auto rejects = [](const std::string& bytes) {
    try {
      SafeTensors::parse(bytes, "bad.safetensors");
    } catch (const InvalidInput& e) {
      return std::string(e.what()).rfind("bad.safetensors: ", 0) == 0;
    }
    return false;
  };
  EXPECT_TRUE(rejects(""));
  EXPECT_TRUE(rejects(good.substr(0, 7)));
  EXPECT_TRUE(rejects(good.substr(0, good.size() - 1)));  // truncated data
  EXPECT_TRUE(rejects(good.substr(0, 8 + n / 2)));        // truncated header
  EXPECT_TRUE(rejects(good + "x"));                       // bytes no tensor claims
  std::string huge = good;
  const uint64_t big = uint64_t(1) << 40;
  std::memcpy(huge.data(), &big, 8);
  EXPECT_TRUE(rejects(huge));
  const auto with_header = [](const std::string& json, size_t data) {
    std::string b(8, '\0');
    const uint64_t len = json.size();
    std::memcpy(b.data(), &len, 8);
    return b + json + std::string(data, '\0');
  };
  EXPECT_TRUE(rejects(with_header(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,4]}})", 4)));   // size mismatch
  EXPECT_TRUE(rejects(with_header(R"({"a":{"dtype":"Q7","shape":[1],"data_offsets":[0,1]}})", 1)));    // unknown dtype
  EXPECT_TRUE(rejects(with_header(R"({"a":{"dtype":"U8","shape":[-1],"data_offsets":[0,1]}})", 1)));   // negative
  EXPECT_TRUE(rejects(with_header(R"({"a":{"dtype":"U8","shape":[1],"data_offsets":[1,2]}})", 2)));    // gap
  EXPECT_TRUE(rejects(with_header(R"({"a":{"dtype":"U8","shape":[2],"data_offsets":[0,2]},)"
                                  R"("b":{"dtype":"U8","shape":[2],"data_offsets":[1,3]}})", 3)));     // overlap
  EXPECT_TRUE(rejects(with_header(R"({"__metadata__":{"k":1}})", 0)));                                 // non-string
  EXPECT_TRUE(rejects(with_header(R"([1,2])", 0)));
  EXPECT_FALSE(rejects(with_header(R"({"__metadata__":{"k":"v"}})", 0))) << "an empty file is valid";
  EXPECT_THROW(SafeTensors::open("/nonexistent/x.safetensors"), IoError);
}

}  // namespace
}  // namespace bareskin
