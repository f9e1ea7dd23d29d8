#include "training/tensorboard.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "core/error.h"
#include "core/files.h"
#include "training/tensorboard_record.h"
#include "tensorboard_event.pb.h"

namespace bareskin {
namespace {

constexpr char kFileVersion[] = "brain.Event:2";
const char kWriteHint[] = "check free disk space and that the run folder is writable";
const char kClosed[] = "an earlier write left a partial record, so the file was closed";

double wall_time() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// The host name with anything but [A-Za-z0-9._-] replaced, so it is safe inside a file name.
std::string host_name() {
  char buffer[256] = {};
  if (gethostname(buffer, sizeof buffer - 1) != 0 || buffer[0] == '\0') return "localhost";
  std::string name(buffer);
  for (char& c : name) {
    const bool safe = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                      c == '_' || c == '-';
    if (!safe) c = '_';
  }
  return name;
}

std::string base_file_name() {
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%010lld", static_cast<long long>(std::time(nullptr)));
  return std::string("events.out.tfevents.") + seconds + "." + host_name() + "." + std::to_string(getpid()) +
         ".bareskin";
}

// Opens a new file for appending; never reuses an existing one (O_EXCL), adding ".2", ".3", ... on a name clash.
int open_new_file(const std::string& dir, std::string& path) {
  const std::string base = dir + "/" + base_file_name();
  for (int n = 1; n < 10000; ++n) {
    path = n == 1 ? base : base + "." + std::to_string(n);
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0644);
    if (fd >= 0) return fd;
    if (errno != EEXIST) throw IoError(path, std::string("cannot create the event file: ") + std::strerror(errno),
                                       kWriteHint);
  }
  throw IoError(base, "cannot create the event file: 10000 files of that name exist", "clean up the run folder");
}

void check_tag(const std::string& tag) { BS_CHECK(!tag.empty(), "a TensorBoard tag must not be empty"); }

}  // namespace

EventWriter::EventWriter(const std::string& run_dir) {
  make_directories(run_dir);
  fd_ = open_new_file(run_dir, path_);
  tensorboard::Event event;
  event.set_wall_time(wall_time());
  event.set_file_version(kFileVersion);
  try {
    append(event.SerializeAsString());
  } catch (...) {
    if (fd_ >= 0) ::close(fd_);
    ::unlink(path_.c_str());  // no empty file without its header
    throw;
  }
}

EventWriter::~EventWriter() {
  if (fd_ >= 0) ::close(fd_);
}

void EventWriter::add_scalar(const std::string& tag, double value, int64_t step) {
  check_tag(tag);
  tensorboard::Event event;
  event.set_wall_time(wall_time());
  event.set_step(step);
  tensorboard::Summary::Value* v = event.mutable_summary()->add_value();
  v->set_tag(tag);
  v->set_simple_value(static_cast<float>(value));
  append(event.SerializeAsString());
}

void EventWriter::add_image(const std::string& tag, const std::string& png_bytes, int height, int width,
                            int channels, int64_t step) {
  check_tag(tag);
  BS_CHECK(height > 0 && width > 0, "image size must be positive");
  BS_CHECK(channels >= 1 && channels <= 4, "image channels must be 1 to 4");
  BS_CHECK(png_bytes.size() >= 8 && png_bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0,
           "TensorBoard images are PNG files");
  tensorboard::Event event;
  event.set_wall_time(wall_time());
  event.set_step(step);
  tensorboard::Summary::Value* v = event.mutable_summary()->add_value();
  v->set_tag(tag);
  tensorboard::Summary::Image* image = v->mutable_image();
  image->set_height(height);
  image->set_width(width);
  image->set_colorspace(channels);
  image->set_encoded_image_string(png_bytes);
  append(event.SerializeAsString());
}

void EventWriter::flush() {
  if (fd_ < 0) throw IoError(path_, kClosed, kWriteHint);
  if (::fdatasync(fd_) != 0) throw IoError(path_, std::string("cannot flush: ") + std::strerror(errno), kWriteHint);
}

// One write() per record; on failure the partial record is cut off again so the file ends on a whole record. If even
// that fails, the writer closes the file: appending after a partial record would hide every later record from readers.
void EventWriter::append(const std::string& event_bytes) {
  if (fd_ < 0) throw IoError(path_, kClosed, kWriteHint);
  const std::string record = tfrecord(event_bytes);
  size_t written = 0;
  while (written < record.size()) {
    const ssize_t n = ::write(fd_, record.data() + written, record.size() - written);
    if (n > 0) {
      written += static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    const std::string reason = n < 0 ? std::strerror(errno) : "nothing written";
    if (::ftruncate(fd_, static_cast<off_t>(size_)) != 0) {
      ::close(fd_);
      fd_ = -1;
      throw IoError(path_, "cannot append an event (" + reason + ") nor cut the partial record off", kWriteHint);
    }
    throw IoError(path_, "cannot append an event (" + reason + "); the file still ends on a whole record", kWriteHint);
  }
  size_ += record.size();
}

}  // namespace bareskin
