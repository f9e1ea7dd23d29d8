#include "training/data.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>
#include <set>

#include "core/error.h"
#include "core/png.h"
#include "core/test_util.h"
#include "core/shards.h"

namespace bareskin::data {
namespace {
namespace fs = std::filesystem;

// A dataset of `count` samples in shards of `per_shard`: an 8x6 RGB image whose first pixel encodes the index, and
// JSON with the index and two landmarks.
std::string make_dataset(int count, int per_shard, bool with_json = true) {
  const std::string dir = testing::temp_dir() + "/data";
  fs::create_directories(dir);
  shards::ShardWriter writer(dir, "train", per_shard);
  for (int i = 0; i < count; ++i) {
    Image image(8, 6, 3);
    image.at(0, 0, 0) = float(i) / 255.f;
    shards::Sample s{fmt::format("{:06d}", i), {{"image.png", encode_png(image)}}};
    if (with_json) s.members["json"] = nlohmann::json{{"index", i}, {"landmarks", {{1.5, 2.5}, {4, 1}}}}.dump();
    writer.write(s);
  }
  shards::Manifest manifest;
  manifest.shards = writer.finish();
  shards::write_manifest(dir, manifest);
  return dir;
}

std::vector<int> indices(DataSource& loader, int batches) {
  std::vector<int> out;
  for (int b = 0; b < batches; ++b) {
    const Batch batch = loader.next();
    for (int64_t i = 0; i < batch.size(); ++i) {
      const int index = batch.meta[i]["index"];
      EXPECT_EQ(std::lround(batch.at("image")[i][0][0][0].item<float>() * 255), index);  // decoded with its JSON
      out.push_back(index);
    }
  }
  return out;
}

TEST(ShardLoader, EveryExampleOncePerEpochInSeededOrder) {
  const auto dir = make_dataset(23, 5);
  LoaderOptions o;
  o.dataset = dir;
  o.batch_size = 23;
  o.shuffle_buffer = 7;
  o.seed = 3;
  ShardLoader loader(o);
  EXPECT_EQ(loader.epoch_size(), 23);
  const auto epoch0 = indices(loader, 1), epoch1 = indices(loader, 1);
  EXPECT_EQ(std::set<int>(epoch0.begin(), epoch0.end()).size(), 23u);
  EXPECT_EQ(std::set<int>(epoch1.begin(), epoch1.end()).size(), 23u);
  EXPECT_NE(epoch0, epoch1);  // a new order every epoch
  EXPECT_NE(epoch0, std::vector<int>(epoch0.size()));
  // The same order whatever the number of decode threads; another seed, another order.
  o.decode_threads = 5;
  ShardLoader again(o);
  EXPECT_EQ(indices(again, 1), epoch0);
  o.seed = 4;
  ShardLoader other(o);
  EXPECT_NE(indices(other, 1), epoch0);
}

TEST(ShardLoader, SeekToCursorContinuesTheSameStream) {
  const auto dir = make_dataset(17, 4);
  LoaderOptions o;
  o.dataset = dir;
  o.batch_size = 3;
  ShardLoader a(o);
  indices(a, 4);
  const Cursor cursor = a.cursor();
  EXPECT_EQ(cursor.epoch, 0);
  EXPECT_EQ(cursor.index, 12);
  const auto rest = indices(a, 5);  // crosses into epoch 1
  ShardLoader b(o);
  b.seek(cursor);
  EXPECT_EQ(indices(b, 5), rest);
}

TEST(ShardLoader, RanksReadDisjointShards) {
  const auto dir = make_dataset(20, 5);  // 4 shards
  std::set<int> all;
  for (int rank = 0; rank < 2; ++rank) {
    LoaderOptions o;
    o.dataset = dir;
    o.batch_size = 10;
    o.rank = rank;
    o.world = 2;
    ShardLoader loader(o);
    EXPECT_EQ(loader.epoch_size(), 10);
    for (int i : indices(loader, 1)) EXPECT_TRUE(all.insert(i).second) << "sample " << i << " on two ranks";
  }
  EXPECT_EQ(all.size(), 20u);
  LoaderOptions o;
  o.dataset = dir;
  o.world = 5;
  o.rank = 4;  // 4 shards, 5 ranks
  EXPECT_THROW(ShardLoader{o}, InvalidInput);
}

TEST(ShardLoader, BadShardsNameTheFile) {
  LoaderOptions o;
  o.dataset = make_dataset(6, 10, /*with_json=*/false);
  o.batch_size = 2;
  o.required = {"image.png", "json"};
  ShardLoader missing(o);
  try {
    missing.next();
    FAIL() << "a sample without its json was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("train-000000.tar"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("json"), std::string::npos) << e.what();
  }
  const std::string dir = testing::temp_dir() + "/corrupt";
  fs::create_directories(dir);
  shards::ShardWriter writer(dir, "x", 10);
  writer.write({"000000", {{"image.png", std::string("\x89PNG\r\n\x1a\n garbage", 17)}}});
  shards::write_manifest(dir, {writer.finish(), {}});
  o.dataset = dir;
  o.required = {};
  ShardLoader corrupt(o);
  EXPECT_THROW(corrupt.next(), InvalidInput);
}

TEST(ShardLoader, DecodesOnlyTheNamedMembers) {
  LoaderOptions o;
  o.dataset = make_dataset(6, 10);
  o.batch_size = 2;
  o.decode = {"json"};
  ShardLoader json_only(o);
  const Batch a = json_only.next();
  EXPECT_EQ(a.tensors.count("image"), 0u);      // dropped undecoded
  EXPECT_EQ(a.tensors.count("landmarks"), 1u);  // from the JSON
  EXPECT_TRUE(a.meta[0].contains("index"));
  o.decode = {"json", "image.png"};
  ShardLoader both(o);
  EXPECT_EQ(both.next().tensors.count("image"), 1u);
}

// A bright block at each landmark: after the random similarity, each dot sits where its landmark went.
TEST(Augment, LandmarksFollowTheImage) {
  for (uint64_t seed = 0; seed < 6; ++seed) {
    Example e;
    e.key = "k";
    const int64_t size = 64;
    auto image = torch::zeros({1, size, size});
    // Each landmark sits at the shared corner of a 2x2 block of bright pixels (a block, not a pixel: a rotated,
    // shrunk pixel may cover no pixel centre of the output).
    auto points = torch::tensor({{20.f, 30.f}, {41.f, 22.f}, {33.f, 45.f}});
    for (int i = 0; i < 3; ++i) {
      const int64_t x = int64_t(points[i][0].item<float>()), y = int64_t(points[i][1].item<float>());
      image[0].slice(0, y - 1, y + 1).slice(1, x - 1, x + 1) = 1;
    }
    e.tensors["image"] = image;
    e.tensors["landmarks"] = points;
    Augment a;
    a.enabled = true;
    a.flip_probability = 0;  // flips need 68 points
    a.nearest = {"image"};   // nearest sampling keeps each dot a single bright pixel
    augment_example(e, a, seed);
    const auto out = e.tensors["image"][0];
    for (int i = 0; i < 3; ++i) {
      const float x = e.tensors["landmarks"][i][0].item<float>(), y = e.tensors["landmarks"][i][1].item<float>();
      const int64_t px = int64_t(std::floor(x)), py = int64_t(std::floor(y));
      const auto window = out.slice(0, py - 1, py + 2).slice(1, px - 1, px + 2);
      EXPECT_EQ(window.max().item<float>(), 1.f) << "seed " << seed << " landmark " << i << " at " << x << "," << y;
    }
  }
}

TEST(Augment, FlipMirrorsAndSwapsLeftRight) {
  Example e;
  e.key = "k";
  auto points = torch::rand({68, 2}) * 50 + 7;
  e.tensors["landmarks"] = points.clone();
  e.tensors["image"] = torch::zeros({3, 64, 64});
  Augment a;
  a.enabled = true;
  a.flip_probability = 1;
  a.shift_pixels = a.scale = a.rotate_degrees = 0;
  augment_example(e, a, 1);
  const auto& mirror = ibug68_mirror();
  for (int i = 0; i < 68; ++i) {
    EXPECT_NEAR(e.tensors["landmarks"][i][0].item<float>(), 64 - points[mirror[i]][0].item<float>(), 1e-4);
    EXPECT_NEAR(e.tensors["landmarks"][i][1].item<float>(), points[mirror[i]][1].item<float>(), 1e-4);
  }
  EXPECT_EQ(mirror[0], 16);
  EXPECT_EQ(mirror[36], 45);
  EXPECT_EQ(mirror[30], 30);
  for (int i = 0; i < 68; ++i) EXPECT_EQ(mirror[mirror[i]], i);
}

}  // namespace
}  // namespace bareskin::data
