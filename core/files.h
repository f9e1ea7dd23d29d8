// Files: atomic output (a temporary beside the target, renamed over it: a crash or an exception leaves the old file
// or nothing, never a partial one), whole-file reads, directories, extensions.
#pragma once
#include <string>
#include <vector>

namespace bareskin {

class AtomicFile {
 public:
  // Checks that the target's directory exists and is writable (IoError otherwise). The temporary keeps the target's
  // extension, so writers that pick a format by extension (OpenImageIO, OpenMesh) work on it.
  explicit AtomicFile(std::string target);
  ~AtomicFile();  // removes the temporary unless commit() succeeded
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& temp_path() const { return temp_; }
  const std::string& target() const { return target_; }
  // fsyncs the temporary and renames it to the target (IoError on failure, e.g. disk full).
  void commit();

 private:
  std::string target_, temp_;
  bool committed_ = false;
};

// A whole output directory made atomically: files are written into a hidden sibling directory, and commit() renames
// it over the target (replacing an older one). Without commit() the partial directory is removed. Only a folder that
// bareskin wrote (it holds the marker file kOutputMarker) or an empty one is replaced: the constructor refuses a file
// or a folder of other files (IoError), which the rename would otherwise delete.
inline constexpr const char* kOutputMarker = ".bareskin-output";
class AtomicDirectory {
 public:
  explicit AtomicDirectory(std::string target);
  ~AtomicDirectory();
  AtomicDirectory(const AtomicDirectory&) = delete;
  AtomicDirectory& operator=(const AtomicDirectory&) = delete;
  const std::string& path() const { return temp_; }  // write here
  void commit();

 private:
  std::string target_, temp_;
  bool committed_ = false;
};

// Checks, before any work, that an output file can be made: its folder exists and is writable and the path is not a
// folder (IoError otherwise; AtomicFile checks the same).
void check_output_file(const std::string& path);

// Refuses (InvalidInput naming `output`) an output path that is one of `inputs`, or that holds one of them (an output
// folder replaces what was there). Empty inputs (flags not given) are skipped.
void check_output_apart(const std::string& output, const std::vector<std::string>& inputs);

// Writes `bytes` to `path` atomically.
void write_file_atomic(const std::string& path, const std::string& bytes);
// Reads a whole file (IoError if missing/unreadable).
std::string read_file(const std::string& path);

// The extension in lower case with its dot (".obj"), or "".
std::string lower_extension(const std::string& path);

// Creates a directory and its parents (IoError when not possible).
void make_directories(const std::string& dir);

}  // namespace bareskin
