// Dataset shards: WebDataset-style tar files. One sample = the consecutive members that share a key, the part of the
// member's name before the first dot of its file name: "000123.makeup.png", "000123.bare.png", "000123.json" are
// the members "makeup.png", "bare.png" and "json" of sample "000123". Any tar tool, Python's tarfile and the
// webdataset package read them. Generators (texgen) write them; the Torch-side loader (training/data.h) reads them.
// docs/file_formats.md describes the format and the manifest.
#pragma once
#include <nlohmann/json.hpp>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace bareskin::shards {

struct Sample {
  std::string key;
  std::map<std::string, std::string> members;  // suffix ("makeup.png", "json") -> bytes
};

// One entry of manifest.json.
struct ShardInfo {
  std::string name;     // file name inside the dataset folder
  int64_t samples = 0;  // samples in it
  uint32_t crc32 = 0;   // of the whole tar file (zlib's CRC-32, as `crc32` / Python's zlib.crc32 print it)
  int64_t bytes = 0;
};

struct Manifest {
  std::vector<ShardInfo> shards;
  nlohmann::json metadata = nlohmann::json::object();  // the generator's options, split, counts, ...
  int64_t samples() const;
};

// Writes "<prefix>-000000.tar", "<prefix>-000001.tar", ... into `dir`, `samples_per_shard` samples each. Every shard
// is written to a temporary and renamed when complete, so a killed generator never leaves a partial shard. The tar
// members carry a fixed time and owner, so the same samples give the same bytes.
class ShardWriter {
 public:
  ShardWriter(std::string dir, std::string prefix, int64_t samples_per_shard);
  ~ShardWriter();
  ShardWriter(const ShardWriter&) = delete;
  ShardWriter& operator=(const ShardWriter&) = delete;

  // InvalidInput for an empty key, a key or suffix with '/', a suffix starting with '.' or a sample without members.
  void write(const Sample& sample);
  // Closes the open shard and returns what was written (for the manifest).
  std::vector<ShardInfo> finish();

 private:
  struct Open;
  void close_shard();
  std::string dir_, prefix_;
  int64_t samples_per_shard_;
  std::unique_ptr<Open> open_;
  std::vector<ShardInfo> written_;
};

// Reads one shard sequentially, a sample at a time.
class ShardReader {
 public:
  explicit ShardReader(const std::string& path);
  ~ShardReader();
  ShardReader(const ShardReader&) = delete;
  ShardReader& operator=(const ShardReader&) = delete;
  // The next sample, false at the end. InvalidInput (naming the shard and member) for a corrupt or truncated tar,
  // a member name without a key, or a key that appears in two separate runs of members; for a link (symbolic or
  // hard), a device or a name that leaves the folder (absolute, '..'); for a member larger than the memory limit
  // (core/memory_limit.h), before it is allocated. Folders are skipped. Nothing is ever written to disk.
  bool next(Sample& sample);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// manifest.json of a dataset folder: {"format": "bareskin-shards/1", "samples": N, "shards": [{"name", "samples",
// "crc32", "bytes"}], "metadata": {...}}. Written atomically.
void write_manifest(const std::string& dir, const Manifest& manifest);
// InvalidInput when missing, malformed, or naming a shard that is not there.
Manifest read_manifest(const std::string& dir);
// The manifest from its text (`path` names it in errors): InvalidInput when malformed, or when a shard's name is not a
// plain file name (a '/', '..') or its counts are negative.
Manifest parse_manifest(const std::string& text, const std::string& path);

// The shard files of a dataset: a folder with manifest.json (its order), or a single .tar file (samples unknown: -1).
// InvalidInput for a folder without manifest or with no shards.
Manifest open_dataset(const std::string& path);
std::string shard_path(const std::string& dataset, const ShardInfo& shard);

// The train and validation splits of a dataset folder: <data>/train and <data>/val (val "" when it is missing or holds
// no samples), or <data> itself as the training split when it has its own manifest.json. InvalidInput naming `data`,
// with `hint`, when there is neither.
struct Splits {
  std::string train, val;
};
Splits find_splits(const std::string& data, const std::string& hint);

// CRC-32 of a file (for the manifest and `bareskin inspect`).
uint32_t file_crc32(const std::string& path);

}  // namespace bareskin::shards
