#include "core/files.h"

#include <fcntl.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "core/error.h"

namespace fs = std::filesystem;

namespace bareskin {
namespace {

// Temporaries are named ".<name>.<tag><pid>-<random>"; one whose process is gone (killed with -9) is removed.
void remove_stale_temporaries(const fs::path& dir, const std::string& prefix) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    if (pid > 0 && ::kill(pid_t(pid), 0) != 0 && errno == ESRCH) fs::remove_all(entry.path(), ec);
  }
}

}  // namespace

void check_output_file(const std::string& target) {
  const fs::path path(target);
  fs::path dir = path.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw IoError(target, "output directory '" + dir.string() + "' does not exist", "create it or choose another output");
  }
  if (access(dir.c_str(), W_OK) != 0) {
    throw IoError(target, "output directory '" + dir.string() + "' is not writable", "check its permissions");
  }
  if (fs::is_directory(path, ec)) throw IoError(target, "is a folder", "give a file name for the output");
}

AtomicFile::AtomicFile(std::string target) : target_(std::move(target)) {
  check_output_file(target_);
  const fs::path path(target_);
  const fs::path dir = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  remove_stale_temporaries(dir, "." + path.stem().string() + ".tmp");
  std::random_device rd;
  temp_ = (dir / ("." + path.stem().string() + ".tmp" + std::to_string(getpid()) + "-" + std::to_string(rd() % 100000) +
                  path.extension().string()))
              .string();
}

AtomicFile::~AtomicFile() {
  if (!committed_) {
    std::error_code ec;
    fs::remove(temp_, ec);
  }
}

void AtomicFile::commit() {
  const int fd = ::open(temp_.c_str(), O_RDONLY);
  if (fd < 0) throw IoError(target_, "the writer produced no file", "see the message before this one");
  const bool synced = ::fsync(fd) == 0;
  const int sync_errno = errno;
  ::close(fd);
  if (!synced) throw IoError(target_, std::string("cannot flush to disk: ") + std::strerror(sync_errno), "check free space");
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) {
    throw IoError(target_, std::string("cannot rename temporary file into place: ") + std::strerror(errno), "");
  }
  committed_ = true;
}

AtomicDirectory::AtomicDirectory(std::string target) : target_(std::move(target)) {
  fs::path path = fs::path(target_).lexically_normal();
  if (path.filename().empty()) path = path.parent_path();
  target_ = path.string();
  const fs::path parent = path.parent_path().empty() ? fs::path(".") : path.parent_path();
  make_directories(parent.string());
  if (access(parent.c_str(), W_OK) != 0) {
    throw IoError(target_, "parent directory '" + parent.string() + "' is not writable", "check its permissions");
  }
  std::error_code ec;
  if (fs::exists(path, ec) && !fs::is_directory(path, ec)) {
    throw IoError(target_, "exists and is a file, not a folder", "choose a folder name for the output");
  }
  if (fs::is_directory(path, ec) && !fs::is_empty(path, ec) && !fs::exists(path / kOutputMarker, ec)) {
    throw IoError(target_, "is a folder of other files (not an earlier bareskin output), which the output would replace",
                  "remove it or choose another output folder");
  }
  remove_stale_temporaries(parent, "." + path.filename().string() + ".partial");
  std::random_device rd;
  temp_ = (parent / ("." + path.filename().string() + ".partial" + std::to_string(getpid()) + "-" +
                     std::to_string(rd() % 100000)))
              .string();
  make_directories(temp_);
  write_file_atomic((fs::path(temp_) / kOutputMarker).string(),
                    "written by bareskin; the next run with this output may replace this folder\n");
}

AtomicDirectory::~AtomicDirectory() {
  std::error_code ec;
  if (!committed_) fs::remove_all(temp_, ec);
}

void AtomicDirectory::commit() {
  std::error_code ec;
  const std::string old = temp_ + ".old";
  const bool had_old = fs::exists(target_, ec);
  if (had_old) {
    fs::rename(target_, old, ec);
    if (ec) throw IoError(target_, "cannot move the previous output aside: " + ec.message(), "");
  }
  fs::rename(temp_, target_, ec);
  if (ec) {
    if (had_old) fs::rename(old, target_, ec);
    throw IoError(target_, "cannot move the new output into place: " + ec.message(), "");
  }
  if (had_old) fs::remove_all(old, ec);
  committed_ = true;
}

void check_output_apart(const std::string& output, const std::vector<std::string>& inputs) {
  const auto resolved = [](const std::string& path) {
    std::error_code ec;
    fs::path p = fs::weakly_canonical(fs::absolute(path, ec), ec).lexically_normal();
    return p.filename().empty() ? p.parent_path() : p;
  };
  const fs::path out = resolved(output);
  for (const std::string& input : inputs) {
    if (input.empty()) continue;
    const fs::path in = resolved(input);
    if (std::mismatch(out.begin(), out.end(), in.begin(), in.end()).first != out.end()) continue;
    throw InvalidInput(output,
                       (in == out ? "is also an input (" : "would replace a folder that holds an input (") + input + ")",
                       "choose another output");
  }
}

void write_file_atomic(const std::string& path, const std::string& bytes) {
  AtomicFile file(path);
  // POSIX calls rather than a stream, so that the message can say why (no space, file too large, quota).
  const int fd = ::open(file.temp_path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw IoError(path, std::string("cannot create: ") + std::strerror(errno), "check permissions");
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : ENOSPC;
      ::close(fd);
      throw IoError(path, std::string("write failed (") + std::strerror(error) + ")",
                    "free disk space (the previous file, if any, is unchanged)");
    }
    done += size_t(n);
  }
  if (::close(fd) != 0)
    throw IoError(path, std::string("write failed (") + std::strerror(errno) + ")",
                  "free disk space (the previous file, if any, is unchanged)");
  file.commit();
}

std::string read_file(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw IoError(path, "no such file", "check the path");
  if (fs::is_directory(path, ec)) throw IoError(path, "is a directory, expected a file", "name a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path, std::string("cannot open: ") + std::strerror(errno), "check its permissions");
  // A regular file in one read into a string of its size (a stream into a growing buffer copied it three times over,
  // a tenth of a second for a 14 MB OBJ); anything else (a pipe, a file that changed size meanwhile) as a stream.
  const auto size = fs::is_regular_file(path, ec) ? fs::file_size(path, ec) : 0;
  if (!ec && size > 0) {
    std::string bytes(size, '\0');
    in.read(bytes.data(), std::streamsize(size));
    if (size_t(in.gcount()) == size && in.peek() == std::char_traits<char>::eof()) return bytes;
    in.clear();
    in.seekg(0);
  }
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

void make_directories(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw IoError(dir, "cannot create directory: " + ec.message(), "check the path and permissions");
}

}  // namespace bareskin
