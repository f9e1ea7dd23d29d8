#include <gtest/gtest.h>

#include "core/error.h"
#include "core/landmarks.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

Landmarks sample(int dims) {
  Landmarks lm;
  lm.units = dims == 3 ? "mm" : "px";
  lm.points.resize(68, dims);
  for (int i = 0; i < 68; ++i) {
    for (int k = 0; k < dims; ++k) lm.points(i, k) = i * 1.25 + k * 0.1 - 3.0;
  }
  return lm;
}

TEST(Landmarks, JsonAndPtsRoundTrip) {
  const std::string dir = testing::temp_dir();
  write_landmarks(dir + "/a.json", sample(3));
  const Landmarks a = read_landmarks(dir + "/a.json");
  EXPECT_EQ(a.scheme, "ibug68");
  EXPECT_EQ(a.units, "mm");
  EXPECT_TRUE(a.points.isApprox(sample(3).points));
  write_landmarks(dir + "/b.pts", sample(2));
  const Landmarks b = read_landmarks(dir + "/b.pts");
  EXPECT_EQ(b.points.cols(), 2);
  EXPECT_TRUE(b.points.isApprox(sample(2).points));
  EXPECT_THROW(write_landmarks(dir + "/c.pts", sample(3)), InvalidInput);
}

TEST(Landmarks, IbugPtsAsWrittenByTheDatasets) {
  std::string text = "version: 1\nn_points:  68\n{\n";
  for (int i = 0; i < 68; ++i) text += std::to_string(100 + i) + ".5 " + std::to_string(200 - i) + "\n";
  text += "}\n";
  const Landmarks lm = parse_landmarks_pts(text, "x.pts");
  EXPECT_DOUBLE_EQ(lm.points(67, 0), 167.5);
  EXPECT_DOUBLE_EQ(lm.points(67, 1), 133.0);
}

TEST(Landmarks, BadInputNamesTheFile) {
  const auto rejects = [](const std::string& text, bool json) {
    try {
      json ? parse_landmarks_json(text, "lm.json") : parse_landmarks_pts(text, "lm.pts");
    } catch (const InvalidInput& e) {
      return std::string(e.what()).rfind("lm.", 0) == 0;
    }
    return false;
  };
  EXPECT_TRUE(rejects("{\"points\": [[1,2,3]", true));                           // truncated JSON
  EXPECT_TRUE(rejects("{\"points\": [[1,2,3],[1,2]]}", true));                   // mixed dims
  EXPECT_TRUE(rejects("{\"points\": [[1,2,3]]}", true));                         // 1 of 68
  EXPECT_TRUE(rejects("{\"scheme\": 3, \"points\": []}", true));                 // wrong type
  EXPECT_TRUE(rejects("{\"scheme\":\"x\",\"points\": [[1,\"a\"]]}", true));      // non-number
  EXPECT_TRUE(rejects("{\"scheme\":\"x\",\"points\": [[1e999, 2]]}", true));     // infinite
  EXPECT_TRUE(rejects("version: 1\nn_points: 68\n{\n1 2\n3 4\n", false));        // truncated
  EXPECT_TRUE(rejects("hello", false));
  EXPECT_NO_THROW(parse_landmarks_json("{\"scheme\":\"custom\",\"points\": [[1,2]]}", "lm.json"));
}

}  // namespace
}  // namespace bareskin
