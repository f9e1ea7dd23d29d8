#include <gtest/gtest.h>

#include <fstream>

#include "core/files.h"
#include "core/error.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

TEST(AtomicFile, ReplacesOnlyOnCommit) {
  const std::string dir = testing::temp_dir(), path = dir + "/out.txt";
  write_file_atomic(path, "old");
  {
    AtomicFile f(path);
    std::ofstream(f.temp_path()) << "new, unfinished";
    // no commit: an exception or crash here must leave the old content
  }
  EXPECT_EQ(read_file(path), "old");
  EXPECT_EQ(testing::count_files(dir), 1u) << "temporary removed";
  {
    AtomicFile f(path);
    EXPECT_EQ(f.temp_path().substr(f.temp_path().size() - 4), ".txt") << "keeps the extension for format sniffing";
    std::ofstream(f.temp_path()) << "new";
    f.commit();
  }
  EXPECT_EQ(read_file(path), "new");
}

TEST(AtomicFile, MissingOrReadOnlyDirectoryIsIoError) {
  EXPECT_THROW(AtomicFile("/nonexistent_dir/a.txt"), IoError);
  EXPECT_THROW(read_file("/nonexistent_dir/a.txt"), IoError);
  EXPECT_THROW(read_file("/"), IoError);
}

}  // namespace
}  // namespace bareskin

namespace bareskin {
namespace {

TEST(AtomicDirectory, AllOrNothing) {
  const std::string root = testing::temp_dir(), target = root + "/out";
  {
    AtomicDirectory dir(target);
    write_file_atomic(dir.path() + "/a.txt", "1");
    // dropped without commit: as if the command failed half way
  }
  EXPECT_FALSE(std::filesystem::exists(target));
  EXPECT_EQ(testing::count_files(root), 0u);
  for (const char* content : {"first", "second"}) {
    AtomicDirectory dir(target + "/");
    write_file_atomic(dir.path() + "/a.txt", content);
    dir.commit();
  }
  EXPECT_EQ(read_file(target + "/a.txt"), "second");
  EXPECT_EQ(testing::count_files(root), 1u);
  EXPECT_TRUE(std::filesystem::exists(target + "/" + kOutputMarker));
  // A writer killed with -9 leaves its temporary behind; the next writer removes it (pid 999999999 is not alive).
  std::filesystem::create_directories(root + "/.out.partial999999999-1");
  testing::write_text(root + "/.a.tmp999999999-2.txt", "stale");
  AtomicDirectory next(target);
  AtomicFile file(root + "/a.txt");
  EXPECT_FALSE(std::filesystem::exists(root + "/.out.partial999999999-1"));
  EXPECT_FALSE(std::filesystem::exists(root + "/.a.tmp999999999-2.txt"));
}

// An output folder replaces only an earlier output or an empty folder: a folder of the user's files, or a file, is
// refused before anything is written, and an output that is or holds an input is refused.
TEST(AtomicDirectory, NeverReplacesWhatItDidNotWrite) {
  const std::string root = testing::temp_dir();
  std::filesystem::create_directories(root + "/mine/maps");
  testing::write_text(root + "/mine/maps/diffuse.png", "not really a png");
  testing::write_text(root + "/file.png", "x");
  EXPECT_THROW(AtomicDirectory(root + "/mine"), IoError);
  EXPECT_THROW(AtomicDirectory(root + "/file.png"), IoError);
  EXPECT_EQ(read_file(root + "/mine/maps/diffuse.png"), "not really a png");
  EXPECT_EQ(testing::count_files(root), 2u);  // no temporary left
  std::filesystem::create_directories(root + "/empty");
  AtomicDirectory(root + "/empty").commit();
  AtomicDirectory(root + "/empty/").commit();  // its own output: replaced
  EXPECT_TRUE(std::filesystem::exists(root + "/empty/" + kOutputMarker));

  const std::string input = root + "/mine/maps/diffuse.png";
  EXPECT_THROW(check_output_apart(root + "/mine", {input}), InvalidInput);
  EXPECT_THROW(check_output_apart(root + "/mine/maps/", {input}), InvalidInput);
  EXPECT_THROW(check_output_apart(root + "/mine/../mine/maps/diffuse.png", {input}), InvalidInput);
  EXPECT_NO_THROW(check_output_apart(root + "/mine/maps/mean.png", {input}));
  EXPECT_NO_THROW(check_output_apart(root + "/min", {input}));
  EXPECT_NO_THROW(check_output_apart(root + "/mine", {root + "/missing.png", ""}));
  EXPECT_THROW(check_output_apart(root + "/fit.json", {root + "/./fit.json"}), InvalidInput);  // neither exists yet
}

}  // namespace
}  // namespace bareskin
