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
  // A writer killed with -9 leaves its temporary behind; the next writer removes it (pid 999999999 is not alive).
  std::filesystem::create_directories(root + "/.out.partial999999999-1");
  testing::write_text(root + "/.a.tmp999999999-2.txt", "stale");
  AtomicDirectory next(target);
  AtomicFile file(root + "/a.txt");
  EXPECT_FALSE(std::filesystem::exists(root + "/.out.partial999999999-1"));
  EXPECT_FALSE(std::filesystem::exists(root + "/.a.tmp999999999-2.txt"));
}

}  // namespace
}  // namespace bareskin
