// A full disk while a file is written, injected with RLIMIT_FSIZE (writes past the limit fail with EFBIG, as with
// ENOSPC): the previous file stays as it was, no temporary is left, and the error is one IoError naming the file.
// Checkpoints are safetensors written this way (training/tensor_io.h -> SafeTensorsWriter::write).
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <functional>
#include <filesystem>
#include <string>

#include "core/error.h"
#include "core/files.h"
#include "core/safetensors.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

// Runs `write` in a child whose file size limit is `limit` bytes; the child's exit code: 0 when the write threw an
// IoError naming `path` on one line, 1 when it succeeded, 2 for anything else.
int write_with_file_limit(const std::string& path, rlim_t limit, const std::function<void()>& write) {
  const pid_t child = fork();
  if (child == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    const rlimit r{limit, limit};
    setrlimit(RLIMIT_FSIZE, &r);
    try {
      write();
    } catch (const IoError& e) {
      const std::string m = e.what();
      _exit(m.rfind(path, 0) == 0 && m.find('\n') == std::string::npos ? 0 : 2);
    } catch (...) {
      _exit(2);
    }
    _exit(1);
  }
  int status = 0;
  waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 3;
}

TEST(AtomicFault, FullDiskKeepsThePreviousFile) {
  const std::string dir = testing::temp_dir(), path = dir + "/checkpoint.safetensors";
  SafeTensorsWriter small, large;
  small.add("w", {4}, std::vector<float>{1, 2, 3, 4});
  large.add("w", {4096}, std::vector<float>(4096, 0.5f));
  small.write(path);
  const std::string before = read_file(path);
  EXPECT_EQ(write_with_file_limit(path, 4096, [&] { large.write(path); }), 0) << "the failed write was not one IoError";
  EXPECT_EQ(read_file(path), before) << "the previous checkpoint changed";
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().filename(), "checkpoint.safetensors") << "a temporary was left: " << e.path();
  // The same write with room succeeds (the limit, not the writer, made it fail).
  EXPECT_EQ(write_with_file_limit(path, 1 << 20, [&] { large.write(path); }), 1);
  EXPECT_EQ(SafeTensors::open(path).tensor("w").numel(), 4096);
}

}  // namespace
}  // namespace bareskin
