#include "training/tensorboard.h"

#include <gtest/gtest.h>
#include <sys/resource.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/test_util.h"
#include "training/tensorboard_record.h"

namespace bareskin {
namespace {

// A 3x2 RGB PNG (made with Python's zlib), small enough to write inline.
const char kPngBytes[] =
    "\x89\x50\x4e\x47\x0d\x0a\x1a\x0a\x00\x00\x00\x0d\x49\x48\x44\x52\x00\x00\x00\x03\x00\x00\x00\x02\x08\x02\x00\x00"
    "\x00\x12\x16\xf1\x4d\x00\x00\x00\x1c\x49\x44\x41\x54\x78\x9c\x63\x60\x60\x60\xd0\xd0\xd0\x08\x08\x08\x60\x88\x8a"
    "\x8a\x6a\x6a\x6a\x5a\xb5\x6a\x15\x00\x26\x66\x05\xfb\x33\xdb\xaa\x5b\x00\x00\x00\x00\x49\x45\x4e\x44\xae\x42\x60"
    "\x82";
const std::string kPng(kPngBytes, sizeof kPngBytes - 1);

std::string hex(const std::string& bytes) {
  std::string out;
  char buf[3];
  for (const unsigned char c : bytes) {
    std::snprintf(buf, sizeof buf, "%02x", c);
    out += buf;
  }
  return out;
}

double now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

struct OracleResult {
  int exit_code = -1;
  std::vector<nlohmann::json> events;
  std::string output;
};

// Runs tests/python/tfevents_oracle.py (standard-library Python, none of our code) on an event file.
OracleResult read_with_oracle(const std::string& file) {
  const std::string command = "/usr/bin/python3 '" BARESKIN_TFEVENTS_ORACLE "' '" + file + "' 2>&1";
  OracleResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return result;
  char buffer[4096];
  size_t n;
  while ((n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0) result.output.append(buffer, n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (result.exit_code == 0) {
    std::istringstream lines(result.output);
    for (std::string line; std::getline(lines, line);) result.events.push_back(nlohmann::json::parse(line));
  }
  return result;
}

TEST(TensorBoardCrc32c, PublishedCheckValues) {
  EXPECT_EQ(crc32c("123456789"), 0xE3069283u);
  // RFC 3720 (iSCSI), appendix B.4.
  EXPECT_EQ(crc32c(std::string(32, '\0')), 0x8A9136AAu);
  EXPECT_EQ(crc32c(std::string(32, '\xff')), 0x62A8AB43u);
}

TEST(TensorBoardRecord, FramesLengthDataAndTheirCrcs) {
  const std::string r = tfrecord("abc");
  ASSERT_EQ(r.size(), 3u + 16u);
  EXPECT_EQ(r.substr(0, 8), std::string("\x03\0\0\0\0\0\0\0", 8)) << "uint64 length, little endian";
  EXPECT_EQ(r.substr(12, 3), "abc");
}

TEST(TensorBoardEventWriter, ScalarsAndImagesRoundTripThroughAnIndependentReader) {
  const std::string run = testing::temp_dir() + "/runs/exp1";  // created by the writer
  const double before = now();
  std::string path;
  {
    EventWriter writer(run);
    path = writer.path();
    writer.add_scalar("loss/total", 0.8125, 0);
    writer.add_scalar("loss/total", 0.1, 1);  // not a float: stored rounded to float32
    writer.add_scalar("lr/generator", -2.5e-4, int64_t(1) << 40);  // a multi-byte varint step
    writer.add_image("samples", kPng, 2, 3, 3, 7);
    writer.add_scalar("eval/psnr", 0.0, 8);  // a zero must still be written
  }
  const double after = now();
  const OracleResult r = read_with_oracle(path);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(r.events.size(), 6u) << r.output;
  EXPECT_EQ(r.events[0]["file_version"], "brain.Event:2");
  for (const auto& e : r.events) {
    EXPECT_GE(e["wall_time"].get<double>(), before - 1e-3);
    EXPECT_LE(e["wall_time"].get<double>(), after + 1e-3);
  }
  const auto scalar = [&](size_t i, const char* tag, int64_t step, float value) {
    EXPECT_EQ(r.events[i]["tag"], tag) << i;
    EXPECT_EQ(r.events[i]["step"].get<int64_t>(), step) << i;
    EXPECT_EQ(r.events[i]["simple_value"].get<double>(), double(value)) << i;
  };
  scalar(1, "loss/total", 0, 0.8125f);
  scalar(2, "loss/total", 1, 0.1f);
  scalar(3, "lr/generator", int64_t(1) << 40, -2.5e-4f);
  scalar(5, "eval/psnr", 8, 0.f);
  const auto& image = r.events[4];
  EXPECT_EQ(image["tag"], "samples");
  EXPECT_EQ(image["step"], 7);
  EXPECT_EQ(image["image"]["height"], 2);
  EXPECT_EQ(image["image"]["width"], 3);
  EXPECT_EQ(image["image"]["colorspace"], 3);
  EXPECT_EQ(image["image"]["png_hex"], hex(kPng));
}

TEST(TensorBoardEventWriter, TheReaderCatchesDamage) {
  const std::string dir = testing::temp_dir();
  std::string path;
  {
    EventWriter writer(dir);
    path = writer.path();
    writer.add_scalar("loss/total", 1.0, 3);
  }
  const std::string good = read_file(path);
  std::string flipped = good;
  flipped[good.size() - 6] ^= 0x01;  // inside the last record's data
  write_file_atomic(dir + "/flipped", flipped);
  write_file_atomic(dir + "/truncated", good.substr(0, good.size() - 2));
  EXPECT_EQ(read_with_oracle(dir + "/flipped").exit_code, 1);
  EXPECT_EQ(read_with_oracle(dir + "/truncated").exit_code, 1);
}

TEST(TensorBoardEventWriter, EveryWriterOpensANewFile) {
  const std::string dir = testing::temp_dir();
  EventWriter first(dir), second(dir);  // e.g. a run and its resumption, within one second
  EXPECT_NE(first.path(), second.path());
  const std::regex name(R"(events\.out\.tfevents\.\d{10}\.[A-Za-z0-9._-]+\.\d+\.bareskin(\.\d+)?)");
  EXPECT_TRUE(std::regex_match(std::filesystem::path(first.path()).filename().string(), name)) << first.path();
  first.add_scalar("loss/total", 2.0, 10);
  second.add_scalar("loss/total", 1.0, 5);
  for (const auto& [path, step] : {std::pair{first.path(), 10}, std::pair{second.path(), 5}}) {
    const OracleResult r = read_with_oracle(path);
    ASSERT_EQ(r.exit_code, 0) << r.output;
    ASSERT_EQ(r.events.size(), 2u);
    EXPECT_EQ(r.events[1]["step"], step);
  }
}

// A write that fails half-way (here: the file size limit, as a full disk would) is cut off again: the file ends on a
// whole record, and later writes go on from there.
TEST(TensorBoardEventWriter, AFailedWriteLeavesOnlyWholeRecords) {
  const std::string dir = testing::temp_dir();
  EventWriter writer(dir);
  writer.add_scalar("loss/total", 0.5, 1);
  const auto size = std::filesystem::file_size(writer.path());
  rlimit old_limit{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old_limit), 0);
  rlimit limit = old_limit;
  limit.rlim_cur = size + 40;  // room for part of the image record only
  auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  EXPECT_THROW(writer.add_image("samples", kPng, 2, 3, 3, 2), IoError);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &old_limit), 0);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_EQ(std::filesystem::file_size(writer.path()), size);
  writer.add_scalar("loss/total", 0.25, 3);
  writer.flush();
  const OracleResult r = read_with_oracle(writer.path());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_EQ(r.events.size(), 3u);
  EXPECT_EQ(r.events[1]["step"], 1);
  EXPECT_EQ(r.events[2]["step"], 3);
}

TEST(TensorBoardEventWriter, AFolderThatCannotBeMadeIsAnIoError) {
  const std::string dir = testing::temp_dir();
  testing::write_text(dir + "/file", "x");
  EXPECT_THROW(EventWriter(dir + "/file/run"), IoError);
}

TEST(TensorBoardEventWriter, CallerMistakesAreBugs) {
  EventWriter writer(testing::temp_dir());
  EXPECT_THROW(writer.add_scalar("", 1.0, 0), InternalError);
  EXPECT_THROW(writer.add_image("samples", "not a png", 2, 3, 3, 0), InternalError);
  EXPECT_THROW(writer.add_image("samples", kPng, 2, 3, 5, 0), InternalError);
}

}  // namespace
}  // namespace bareskin
