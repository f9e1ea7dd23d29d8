// TensorBoard event files (`tensorboard --logdir runs/`): scalars and PNG images of a training run.
//
// An event file is an append log of TFRecord records (training/tensorboard_record.h), each a serialized Event
// (training/tensorboard_event.proto). Atomic rename does not fit a log that grows for days, so instead every add
// appends one whole record with a single write() and rolls the file back to its last whole record if the write fails
// (disk full), so no complete-looking corrupt record is ever left; a kill -9 during a write can at worst leave a
// truncated last record, which TensorBoard reads as "not yet written" and ignores. Each add reaches the operating
// system before it returns (readers see it at once); flush() also forces it to disk.
//
// Resuming a run: the trainer opens a NEW EventWriter (a new file; names start with the Unix time, so they sort in
// order). TensorBoard merges all event files of a run folder in name order, and when a tag's steps go backwards (the
// resumed run restarts at its checkpoint's step) it drops the older file's points past that step.
//
// Built only where protobuf is found; users of it check BARESKIN_WITH_TENSORBOARD. Not thread-safe.
#pragma once
#include <cstdint>
#include <string>

namespace bareskin {

class EventWriter {
 public:
  // Creates run_dir if needed and a new file events.out.tfevents.<unix time>.<hostname>.<pid>.bareskin in it (a
  // ".<n>" suffix if that name exists), whose first record is the file_version event "brain.Event:2".
  // IoError when the folder or the file cannot be made.
  explicit EventWriter(const std::string& run_dir);
  ~EventWriter();
  EventWriter(const EventWriter&) = delete;
  EventWriter& operator=(const EventWriter&) = delete;

  // A point of the scalar chart `tag` (stored as float32, as TensorBoard does; NaN and infinities are kept).
  void add_scalar(const std::string& tag, double value, int64_t step);
  // A PNG file's bytes shown under `tag`; height/width in pixels, channels 1 (grey), 2 (grey+alpha), 3 (RGB), 4 (RGBA).
  void add_image(const std::string& tag, const std::string& png_bytes, int height, int width, int channels,
                 int64_t step);
  // Forces what was added to disk (fdatasync). IoError on failure.
  void flush();

  const std::string& path() const { return path_; }

 private:
  void append(const std::string& event_bytes);

  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;  // bytes of whole records in the file
};

}  // namespace bareskin
