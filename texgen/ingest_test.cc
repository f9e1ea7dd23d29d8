// texgen ingest-pairs without the Torch side: a stand-in detector (a fixed 68-point face on bright photos, none on dark
// ones) checks pairing, alignment, masks, the shard members and all-or-nothing output. tests/cli/texgen_ingest.sh runs
// the real detector on a real photo.
#include "texgen/ingest.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "core/error.h"
#include "core/image_io.h"
#include "core/png.h"
#include "core/test_util.h"
#include "template/template_face.h"
#include "core/shards.h"

namespace bareskin::texgen {
namespace {
namespace fs = std::filesystem;

// The template's landmarks seen from the front: x right, y down, 1.3 px per mm around (150, 140).
detect::Landmarks68 fixed_face() {
  static const detect::Landmarks68 points = [] {
    const TemplateFace face = read_template(std::string(BARESKIN_TEMPLATE_DIR) + "/face.obj",
                                            std::string(BARESKIN_TEMPLATE_DIR) + "/landmarks.json");
    detect::Landmarks68 p;
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d v = face.mesh.V.row(face.landmark_vertices[size_t(k)]);
      p.row(k) << 150 + 1.3 * v.x(), 140 - 1.3 * v.y();
    }
    return p;
  }();
  return points;
}

detect::PhotoDetector fake_detector(int* calls) {
  return [calls](const Image& photo) {
    ++*calls;
    std::vector<detect::PhotoFace> faces;
    if (photo.at(photo.width / 2, photo.height / 2, 0) > 0.3f) faces.push_back({0.9, fixed_face()});
    return faces;
  };
}

// A skin-coloured photo (passes the YCbCr box) or a dark one (no face for the fake detector).
void write_photo(const std::string& path, bool face) {
  Image img(300, 300, 3, ColorSpace::sRGB);
  for (size_t i = 0; i < img.pixels.size(); ++i)
    img.pixels[i] = face ? (i % 3 == 0 ? 0.8f : i % 3 == 1 ? 0.6f : 0.5f) : 0.05f;
  write_image(path, img);
}

struct Folders {
  std::string root = testing::temp_dir(), before = root + "/before", after = root + "/after", out = root + "/real";
  Folders() {
    fs::create_directories(before);
    fs::create_directories(after);
  }
  ~Folders() { fs::remove_all(root); }
};

TEST(IngestPairs, AlignsPairsIntoFaceShardsWithLandmarkMasks) {
  Folders f;
  write_photo(f.before + "/a.png", true);
  write_photo(f.after + "/a.jpg", true);  // stems pair across extensions
  write_photo(f.before + "/b.png", true);
  write_photo(f.after + "/b.png", true);
  IngestOptions o;
  o.before_dir = f.before;
  o.after_dir = f.after;
  o.output = f.out;
  int calls = 0;
  const IngestReport report = ingest_pairs(o, fake_detector(&calls));
  EXPECT_EQ(report.written, 2);
  EXPECT_EQ(calls, 4);
  const shards::Manifest m = shards::read_manifest(f.out);
  ASSERT_EQ(m.samples(), 2);
  EXPECT_FALSE(m.metadata.at("has_truth").get<bool>());
  shards::ShardReader reader(shards::shard_path(f.out, m.shards[0]));
  shards::Sample s;
  ASSERT_TRUE(reader.next(s));
  EXPECT_EQ(s.key, "00000000");
  for (const char* name : {"makeup.png", "before.png", "skin.png", "face.png", "json"})
    EXPECT_TRUE(s.members.count(name)) << name;
  for (const char* name : {"bare.png", "layer.png"}) EXPECT_FALSE(s.members.count(name)) << name;
  const nlohmann::json meta = nlohmann::json::parse(s.members.at("json"));
  EXPECT_EQ(meta.at("subject"), "real/a");
  EXPECT_FALSE(meta.at("has_truth").get<bool>());
  detect::Landmarks68 aligned;
  for (int k = 0; k < 68; ++k)
    aligned.row(k) << meta["landmarks"][size_t(k)][0].get<double>(), meta["landmarks"][size_t(k)][1].get<double>();
  // A least-squares scale + translation maps the mean of the five points onto the mean of the standard five exactly.
  const Eigen::RowVector2d mean = detect::five_points(aligned).colwise().mean();
  const Eigen::RowVector2d target = detect::standard_five_points().colwise().mean();
  EXPECT_LT((mean - target).norm(), 1e-6);
  // The aligned landmarks are the detected ones through the stored similarity.
  const auto& sim = meta.at("align").at("similarity");
  const double scale = sim[0][0].get<double>();
  EXPECT_NEAR(aligned(30, 0), scale * fixed_face()(30, 0) + sim[0][2].get<double>(), 1e-9);
  // Masks: the lips and the eyes are out of skin.png, the cheek is in; face.png keeps the lips.
  const Image skin = decode_png(s.members.at("skin.png"), "skin"), face = decode_png(s.members.at("face.png"), "face");
  ASSERT_EQ(skin.width, 256);
  const auto at = [](const Image& img, const Eigen::Vector2d& p) { return img.at(int(p.x()), int(p.y())); };
  Eigen::Vector2d mouth = Eigen::Vector2d::Zero(), eye = Eigen::Vector2d::Zero();
  for (int k = 48; k < 60; ++k) mouth += aligned.row(k).transpose() / 12;
  for (int k = 36; k < 42; ++k) eye += aligned.row(k).transpose() / 6;
  const Eigen::Vector2d cheek = (aligned.row(2) + aligned.row(31) + aligned.row(41)).transpose() / 3;
  EXPECT_EQ(at(skin, mouth), 0.0f);
  EXPECT_EQ(at(skin, eye), 0.0f);
  EXPECT_EQ(at(face, mouth), 1.0f);
  EXPECT_EQ(at(skin, cheek), 1.0f);
  EXPECT_EQ(at(face, {5.0, 5.0}), 0.0f);  // outside the hull
}

TEST(IngestPairs, UnmatchedOrFacelessPhotosFailWithNothingWrittenOrAreListed) {
  Folders f;
  write_photo(f.before + "/a.png", true);
  write_photo(f.after + "/a.png", true);
  write_photo(f.before + "/dark.png", true);
  write_photo(f.after + "/dark.png", false);
  IngestOptions o;
  o.before_dir = f.before;
  o.after_dir = f.after;
  o.output = f.out;
  int calls = 0;
  EXPECT_THROW(ingest_pairs(o, fake_detector(&calls)), InvalidInput);
  EXPECT_FALSE(fs::exists(f.out));
  EXPECT_EQ(testing::count_files(f.root), 2u);  // before/, after/: no temporary left behind
  o.keep_going = true;
  const IngestReport kept = ingest_pairs(o, fake_detector(&calls));
  EXPECT_EQ(kept.written, 1);
  ASSERT_EQ(kept.undetected.size(), 1u);
  EXPECT_EQ(fs::path(kept.undetected[0]).filename(), "dark.png");
  fs::remove_all(f.out);
  write_photo(f.after + "/lonely.png", true);
  o.keep_going = false;
  try {
    ingest_pairs(o, fake_detector(&calls));
    FAIL() << "an unmatched photo was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("lonely.png"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(f.out));
}

TEST(IngestPairs, YCbCrSkinBox) {
  EXPECT_TRUE(ycbcr_skin(0.8f, 0.6f, 0.5f));    // light skin: Cb 107, Cr 156
  EXPECT_TRUE(ycbcr_skin(0.45f, 0.3f, 0.22f));  // dark skin
  EXPECT_FALSE(ycbcr_skin(0.2f, 0.3f, 0.8f));   // blue
  EXPECT_FALSE(ycbcr_skin(0.5f, 0.5f, 0.5f));   // grey: Cr 128
}

}  // namespace
}  // namespace bareskin::texgen
