#include "core/shards.h"

#include <gtest/gtest.h>
#include <fmt/format.h>
#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/memory_limit.h"
#include "core/test_util.h"

namespace bareskin::shards {
namespace {
namespace fs = std::filesystem;

Sample make_sample(int i) {
  Sample s;
  char key[16];
  std::snprintf(key, sizeof(key), "%06d", i);
  s.key = key;
  s.members["json"] = "{\"index\": " + std::to_string(i) + "}";
  s.members["makeup.png"] = std::string(size_t(100 + 37 * i), char('a' + i % 26));  // any bytes; sizes vary
  if (i % 3 == 0) s.members["bare.png"] = std::string(size_t(513 * i), '\0');  // 0 bytes for sample 0
  return s;
}

// One handmade ustar member: a 512-byte header (name, type, size in octal, link target, checksum) and the body padded
// to 512 bytes. `size` is what the header claims (by default the body's length).
std::string tar_member(const std::string& name, char type, const std::string& body, const std::string& link = "",
                       int64_t size = -1) {
  std::string h(512, '\0');
  name.copy(&h[0], std::min<size_t>(name.size(), 100));
  std::snprintf(&h[100], 8, "%07o", 0644);
  std::snprintf(&h[108], 8, "%07o", 0);
  std::snprintf(&h[116], 8, "%07o", 0);
  std::snprintf(&h[124], 12, "%011llo", static_cast<unsigned long long>(size >= 0 ? size : int64_t(body.size())));
  std::snprintf(&h[136], 12, "%011o", 0);
  h[156] = type;
  link.copy(&h[157], std::min<size_t>(link.size(), 100));
  std::memcpy(&h[257], "ustar\0" "00", 8);
  std::memset(&h[148], ' ', 8);
  unsigned sum = 0;
  for (unsigned char c : h) sum += c;
  std::snprintf(&h[148], 8, "%06o", sum);
  return h + body + std::string((512 - body.size() % 512) % 512, '\0');
}

// The message the reader gives for a shard of these members (after a good sample), "" when it reads to the end.
std::string read_error(const std::string& path, const std::string& members) {
  write_file_atomic(path, tar_member("000000.json", '0', "{}") + members + std::string(1024, '\0'));
  try {
    ShardReader reader(path);
    Sample s;
    while (reader.next(s)) {
    }
  } catch (const InvalidInput& e) {
    return e.what();
  }
  return "";
}

std::string temp_dir(const std::string& name) { return testing::temp_dir() + "/" + name; }

std::vector<Sample> write_dataset(const std::string& dir, int count, int per_shard) {
  fs::create_directories(dir);
  ShardWriter writer(dir, "train", per_shard);
  std::vector<Sample> samples;
  for (int i = 0; i < count; ++i) {
    samples.push_back(make_sample(i));
    writer.write(samples.back());
  }
  Manifest manifest;
  manifest.shards = writer.finish();
  manifest.metadata = {{"split", "train"}};
  write_manifest(dir, manifest);
  return samples;
}

TEST(Shards, RoundTripAcrossShardsWithManifest) {
  const auto dir = temp_dir("roundtrip");
  const auto samples = write_dataset(dir, 11, 4);
  const Manifest manifest = open_dataset(dir);
  ASSERT_EQ(manifest.shards.size(), 3u);
  EXPECT_EQ(manifest.shards[0].name, "train-000000.tar");
  EXPECT_EQ(manifest.shards[2].samples, 3);
  EXPECT_EQ(manifest.samples(), 11);
  EXPECT_EQ(manifest.metadata["split"], "train");
  size_t next = 0;
  for (const auto& shard : manifest.shards) {
    EXPECT_EQ(file_crc32(shard_path(dir, shard)), shard.crc32);
    ShardReader reader(shard_path(dir, shard));
    Sample s;
    while (reader.next(s)) {
      ASSERT_LT(next, samples.size());
      EXPECT_EQ(s.key, samples[next].key);
      EXPECT_EQ(s.members, samples[next].members);
      ++next;
    }
  }
  EXPECT_EQ(next, samples.size());
}

TEST(Shards, SameSamplesGiveSameBytes) {
  const auto a = temp_dir("bytes_a"), b = temp_dir("bytes_b");
  write_dataset(a, 5, 10);
  write_dataset(b, 5, 10);
  EXPECT_EQ(read_file(a + "/train-000000.tar"), read_file(b + "/train-000000.tar"));
}

// Python's tarfile (an independent reader) sees the same samples, grouped by key as webdataset groups them.
TEST(Shards, PythonTarfileGroupsMembersByKey) {
  const auto dir = temp_dir("python");
  const auto samples = write_dataset(dir, 7, 100);
  std::ostringstream expected;
  for (const auto& s : samples) {
    expected << s.key;
    for (const auto& [suffix, bytes] : s.members)  // std::map: sorted like Python's sorted()
      expected << " " << suffix << "=" << fmt::format("{:08x}", uint32_t(crc32(0, reinterpret_cast<const Bytef*>(bytes.data()), uInt(bytes.size()))));
    expected << "\n";
  }
  const std::string out = dir + "/python.txt";
  const std::string command = std::string("/usr/bin/python3 ") + BARESKIN_SOURCE_DIR +
                              "/tests/python/webdataset_oracle.py " + dir + "/train-000000.tar > " + out;
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  EXPECT_EQ(read_file(out), expected.str());
}

TEST(Shards, TruncatedShardNamesFileAndMember) {
  const auto dir = temp_dir("truncated");
  write_dataset(dir, 6, 100);
  const std::string path = dir + "/train-000000.tar";
  const std::string bytes = read_file(path);
  write_file_atomic(path, bytes.substr(0, 2000));
  ShardReader reader(path);
  Sample s;
  try {
    while (reader.next(s)) {
    }
    FAIL() << "a truncated shard was read to the end";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(Shards, HostileMembersAreRefusedNamingTheMember) {
  const auto dir = temp_dir("hostile");
  fs::create_directories(dir);
  const std::string path = dir + "/hostile-000000.tar";
  // The handmade writer makes files Python's tarfile reads: a folder member is skipped, the sample is read.
  EXPECT_EQ(read_error(path, tar_member("sub/", '5', "") + tar_member("000001.json", '0', "{}")), "");
  const struct {
    std::string members, expected;
  } cases[] = {
      {tar_member("../x.json", '0', "{}"), "member '../x.json' has a name that leaves the shard's folder"},
      {tar_member("a/../../000001.json", '0', "{}"), "member 'a/../../000001.json' has a name that leaves"},
      {tar_member("/etc/x.json", '0', "{}"), "member '/etc/x.json' has a name that leaves"},
      {tar_member("000001.json", '2', "", "/etc/passwd"), "member '000001.json' is a link"},
      {tar_member("000001.json", '1', "", "000000.json"), "member '000001.json' is a link"},
      {tar_member("000001.dev", '3', ""), "member '000001.dev' is not a plain file"},
      {tar_member("000001.fifo", '6', ""), "member '000001.fifo' is not a plain file"},
  };
  for (const auto& c : cases) {
    const std::string m = read_error(path, c.members);
    EXPECT_EQ(m.rfind(path + ": ", 0), 0u) << m;
    EXPECT_NE(m.find(c.expected), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
  // A header promising more than the memory limit is refused before the member is allocated (the body is absent).
  set_max_memory("1M");
  const std::string big = read_error(path, tar_member("000001.png", '0', "", "", int64_t(3) << 30));
  set_max_memory("8G");
  EXPECT_NE(big.find("member '000001.png' needs 3.22 GB, more than the memory limit of 0.001 GB"), std::string::npos) << big;
  // A manifest naming a shard outside the folder is refused.
  Manifest outside;
  outside.shards.push_back({"../hostile/hostile-000000.tar", 1, 0, 10});
  write_manifest(dir, outside);
  EXPECT_THROW(read_manifest(dir), InvalidInput);
  EXPECT_THROW(parse_manifest(R"({"format": "bareskin-shards/1", "shards": [{"name": "/etc/passwd", "samples": 1,
                                  "crc32": 0, "bytes": 1}]})", "m.json"), InvalidInput);
}

TEST(Shards, BadInput) {
  const auto dir = temp_dir("bad");
  fs::create_directories(dir);
  EXPECT_THROW(open_dataset(dir), InvalidInput);  // no manifest
  write_manifest(dir, Manifest{});
  EXPECT_THROW(open_dataset(dir), InvalidInput);  // empty dataset
  Manifest missing;
  missing.shards.push_back({"train-000000.tar", 3, 0, 10});
  write_manifest(dir, missing);
  EXPECT_THROW(open_dataset(dir), InvalidInput);  // listed shard not there
  ShardWriter writer(dir, "x", 2);
  EXPECT_THROW(writer.write(Sample{"a.b", {{"json", "{}"}}}), InvalidInput);
  EXPECT_THROW(writer.write(Sample{"k", {}}), InvalidInput);
  EXPECT_THROW(writer.write(Sample{"k", {{".png", ""}}}), InvalidInput);
  // A key split into two runs of members is refused: webdataset would see two samples.
  Sample a{"000001", {{"json", "1"}}}, b{"000002", {{"json", "2"}}};
  ShardWriter w2(dir, "dup", 10);
  w2.write(a);
  w2.write(b);
  w2.write(a);
  w2.finish();
  ShardReader reader(dir + "/dup-000000.tar");
  Sample s;
  EXPECT_TRUE(reader.next(s));
  EXPECT_TRUE(reader.next(s));
  EXPECT_THROW(reader.next(s), InvalidInput);
}

}  // namespace
}  // namespace bareskin::shards
