#include "core/shards.h"

#include <archive.h>
#include <archive_entry.h>
#include <zlib.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "core/error.h"
#include "core/files.h"
#include "core/memory_limit.h"

namespace bareskin::shards {
namespace fs = std::filesystem;

namespace {

constexpr const char* kFormat = "bareskin-shards/1";
constexpr const char* kHostile = "the shard was not written by a dataset generator; do not use it, regenerate it";
constexpr const char* kRegenerate = "regenerate the dataset (its generator resumes) or remove the shard from manifest.json";

// Member "dir/000123.makeup.png" -> key "dir/000123", suffix "makeup.png". False when the file name has no dot.
bool split_member(const std::string& name, std::string& key, std::string& suffix) {
  const size_t slash = name.rfind('/');
  const size_t dot = name.find('.', slash == std::string::npos ? 0 : slash + 1);
  if (dot == std::string::npos || dot == 0 || dot + 1 == name.size()) return false;
  key = name.substr(0, dot);
  suffix = name.substr(dot + 1);
  return true;
}

// True when a '/'-separated name has a ".." part.
bool has_parent_part(const std::string& name) {
  size_t begin = 0;
  for (;;) {
    const size_t end = name.find('/', begin);
    if (name.compare(begin, end == std::string::npos ? std::string::npos : end - begin, "..") == 0) return true;
    if (end == std::string::npos) return false;
    begin = end + 1;
  }
}

}  // namespace

int64_t Manifest::samples() const {
  int64_t total = 0;
  for (const auto& s : shards) total += s.samples;
  return total;
}

uint32_t file_crc32(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path, "cannot be read", "check the path and its permissions");
  uLong crc = crc32(0L, Z_NULL, 0);
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), std::streamsize(buffer.size()));
    crc = crc32(crc, reinterpret_cast<const Bytef*>(buffer.data()), uInt(in.gcount()));
  }
  return uint32_t(crc);
}

// ---- writer ----

struct ShardWriter::Open {
  std::unique_ptr<AtomicFile> file;
  archive* tar = nullptr;
  int64_t samples = 0;
  ShardInfo info;
  ~Open() {
    if (tar) archive_write_free(tar);
  }
};

ShardWriter::ShardWriter(std::string dir, std::string prefix, int64_t samples_per_shard)
    : dir_(std::move(dir)), prefix_(std::move(prefix)), samples_per_shard_(samples_per_shard) {
  BS_CHECK(samples_per_shard_ > 0, "samples per shard must be positive");
  make_directories(dir_);
}

ShardWriter::~ShardWriter() = default;  // an unfinished shard's temporary is removed by AtomicFile

void ShardWriter::write(const Sample& sample) {
  const std::string where = "sample '" + sample.key + "'";
  if (sample.key.empty() || sample.key.find('.') != std::string::npos || sample.key.find('/') != std::string::npos)
    throw InvalidInput(where, "a key must be non-empty without '.' or '/'", "name samples like 000123");
  if (sample.members.empty()) throw InvalidInput(where, "has no members", "give every sample at least one file");
  for (const auto& [suffix, bytes] : sample.members)
    if (suffix.empty() || suffix[0] == '.' || suffix.find('/') != std::string::npos)
      throw InvalidInput(where, "member suffix '" + suffix + "' is not a plain extension", "use e.g. 'makeup.png'");
  if (!open_) {
    char name[64];
    std::snprintf(name, sizeof(name), "-%06zu.tar", written_.size());
    open_ = std::make_unique<Open>();
    open_->info.name = prefix_ + name;
    open_->file = std::make_unique<AtomicFile>(dir_ + "/" + open_->info.name);
    open_->tar = archive_write_new();
    archive_write_set_format_ustar(open_->tar);
    if (archive_write_open_filename(open_->tar, open_->file->temp_path().c_str()) != ARCHIVE_OK)
      throw IoError(open_->file->target(), std::string("cannot be written (") + archive_error_string(open_->tar) + ")",
                    "check the folder's permissions and free space");
  }
  for (const auto& [suffix, bytes] : sample.members) {
    archive_entry* entry = archive_entry_new();
    archive_entry_set_pathname(entry, (sample.key + "." + suffix).c_str());
    archive_entry_set_size(entry, la_int64_t(bytes.size()));
    archive_entry_set_filetype(entry, AE_IFREG);
    archive_entry_set_perm(entry, 0644);
    archive_entry_set_mtime(entry, 0, 0);  // fixed: the same samples give the same bytes
    const bool ok = archive_write_header(open_->tar, entry) == ARCHIVE_OK &&
                    archive_write_data(open_->tar, bytes.data(), bytes.size()) == la_ssize_t(bytes.size());
    archive_entry_free(entry);
    if (!ok)
      throw IoError(open_->file->target(), std::string("write failed (") + archive_error_string(open_->tar) + ")",
                    "check free space");
  }
  if (++open_->samples == samples_per_shard_) close_shard();
}

void ShardWriter::close_shard() {
  if (!open_) return;
  if (archive_write_close(open_->tar) != ARCHIVE_OK)
    throw IoError(open_->file->target(), std::string("write failed (") + archive_error_string(open_->tar) + ")",
                  "check free space");
  open_->info.samples = open_->samples;
  open_->info.crc32 = file_crc32(open_->file->temp_path());
  open_->info.bytes = int64_t(fs::file_size(open_->file->temp_path()));
  open_->file->commit();
  written_.push_back(open_->info);
  open_.reset();
}

std::vector<ShardInfo> ShardWriter::finish() {
  close_shard();
  return written_;
}

// ---- reader ----

struct ShardReader::State {
  std::string path;
  archive* tar = nullptr;
  std::string pending_key, pending_suffix, pending_bytes;  // the first member of the next sample
  bool has_pending = false, done = false;
  std::set<std::string> seen;
  ~State() {
    if (tar) archive_read_free(tar);
  }
  [[noreturn]] void corrupt(const std::string& what) const {
    throw InvalidInput(path, what, kRegenerate);
  }
  // Reads the next member; false at the end of the archive. Folders are skipped; links, devices and names that
  // would leave a folder (absolute, '..') are refused, naming the member: a shard holds plain files only.
  bool read_member(std::string& key, std::string& suffix, std::string& bytes) {
    archive_entry* entry = nullptr;
    for (;;) {
      const int status = archive_read_next_header(tar, &entry);
      if (status == ARCHIVE_EOF) return false;
      if (status != ARCHIVE_OK) corrupt(std::string("corrupt tar (") + archive_error_string(tar) + ")");
      if (archive_entry_filetype(entry) != AE_IFDIR) break;
    }
    const char* path = archive_entry_pathname(entry);
    const std::string name = path ? path : "";
    check_member(entry, name);
    if (!split_member(name, key, suffix))
      corrupt("member '" + name + "' has no key.suffix name");
    const la_int64_t size = archive_entry_size(entry);
    if (size < 0) corrupt("member '" + name + "' has a negative size");
    check_memory(this->path, double(size), "member '" + name + "'");
    bytes.resize(size_t(size));
    la_ssize_t got = 0;
    while (got < size) {
      const la_ssize_t n = archive_read_data(tar, bytes.data() + got, size_t(size - got));
      if (n <= 0) corrupt("member '" + name + "' is truncated (" + (n < 0 ? archive_error_string(tar) : "end of file") + ")");
      got += n;
    }
    return true;
  }
  void check_member(archive_entry* entry, const std::string& name) const {
    if (archive_entry_hardlink(entry) || archive_entry_filetype(entry) == AE_IFLNK)
      throw InvalidInput(path, "member '" + name + "' is a link (a shard holds plain files only)", kHostile);
    if (archive_entry_filetype(entry) != AE_IFREG)
      throw InvalidInput(path, "member '" + name + "' is not a plain file (a shard holds plain files only)", kHostile);
    if (name.empty() || name[0] == '/' || name.find('\\') != std::string::npos || has_parent_part(name))
      throw InvalidInput(path, "member '" + name + "' has a name that leaves the shard's folder", kHostile);
  }
};

ShardReader::ShardReader(const std::string& path) : state_(std::make_unique<State>()) {
  state_->path = path;
  if (!fs::is_regular_file(path)) throw IoError(path, "not found", "check the dataset folder and its manifest.json");
  state_->tar = archive_read_new();
  archive_read_support_format_tar(state_->tar);
  if (archive_read_open_filename(state_->tar, path.c_str(), 1 << 20) != ARCHIVE_OK)
    state_->corrupt(std::string("cannot be opened as tar (") + archive_error_string(state_->tar) + ")");
}

ShardReader::~ShardReader() = default;

bool ShardReader::next(Sample& sample) {
  State& s = *state_;
  if (s.done) return false;
  if (!s.has_pending && !s.read_member(s.pending_key, s.pending_suffix, s.pending_bytes)) {
    s.done = true;
    return false;
  }
  sample.key = s.pending_key;
  sample.members.clear();
  if (!s.seen.insert(sample.key).second)
    s.corrupt("sample '" + sample.key + "' appears twice (its members must be consecutive)");
  sample.members[s.pending_suffix] = std::move(s.pending_bytes);
  s.has_pending = false;
  std::string key, suffix, bytes;
  while (s.read_member(key, suffix, bytes)) {
    if (key != sample.key) {
      s.pending_key = std::move(key);
      s.pending_suffix = std::move(suffix);
      s.pending_bytes = std::move(bytes);
      s.has_pending = true;
      return true;
    }
    if (!sample.members.emplace(suffix, std::move(bytes)).second)
      s.corrupt("sample '" + sample.key + "' has two members '" + suffix + "'");
  }
  s.done = true;
  return true;
}

// ---- manifest ----

void write_manifest(const std::string& dir, const Manifest& manifest) {
  nlohmann::json j;
  j["format"] = kFormat;
  j["samples"] = manifest.samples();
  j["shards"] = nlohmann::json::array();
  for (const auto& s : manifest.shards)
    j["shards"].push_back({{"name", s.name}, {"samples", s.samples}, {"crc32", s.crc32}, {"bytes", s.bytes}});
  j["metadata"] = manifest.metadata;
  write_file_atomic(dir + "/manifest.json", j.dump(2) + "\n");
}

Manifest parse_manifest(const std::string& text, const std::string& path) {
  Manifest manifest;
  try {
    const auto j = nlohmann::json::parse(text);
    if (j.at("format").get<std::string>() != kFormat)
      throw InvalidInput(path, "format '" + j.at("format").get<std::string>() + "' is not " + kFormat,
                         "regenerate the dataset with this version");
    for (const auto& s : j.at("shards"))
      manifest.shards.push_back({s.at("name").get<std::string>(), s.at("samples").get<int64_t>(),
                                 s.at("crc32").get<uint32_t>(), s.at("bytes").get<int64_t>()});
    if (j.contains("metadata")) manifest.metadata = j["metadata"];
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(path, std::string("malformed (") + e.what() + ")", "regenerate the dataset");
  }
  for (const auto& s : manifest.shards) {
    if (s.name.empty() || s.name == "." || s.name == ".." || s.name.find('/') != std::string::npos ||
        s.name.find('\\') != std::string::npos)
      throw InvalidInput(path, "shard name '" + s.name + "' is not a file name in the dataset's folder",
                         "the manifest is corrupt or hostile; regenerate the dataset");
    if (s.samples < 0 || s.bytes < 0)
      throw InvalidInput(path, "shard '" + s.name + "' has a negative count", "regenerate the dataset");
  }
  return manifest;
}

Manifest read_manifest(const std::string& dir) {
  const std::string path = dir + "/manifest.json";
  if (!fs::is_regular_file(path))
    throw InvalidInput(dir, "has no manifest.json (not a dataset folder)", "point at the folder a texgen command wrote");
  Manifest manifest = parse_manifest(read_file(path), path);
  for (const auto& s : manifest.shards)
    if (!fs::is_regular_file(dir + "/" + s.name))
      throw InvalidInput(dir + "/" + s.name, "is listed in manifest.json but missing", kRegenerate);
  return manifest;
}

Splits find_splits(const std::string& data, const std::string& hint) {
  if (fs::exists(fs::path(data) / "manifest.json")) return {data, ""};
  const fs::path train = fs::path(data) / "train", val = fs::path(data) / "val";
  if (!fs::exists(train / "manifest.json")) throw InvalidInput(data, "has no train/manifest.json (nor manifest.json)", hint);
  // An empty val/ (few subjects) means no validation.
  const bool has_val = fs::exists(val / "manifest.json") && read_manifest(val.string()).samples() > 0;
  return {train.string(), has_val ? val.string() : ""};
}

Manifest open_dataset(const std::string& path) {
  if (fs::is_regular_file(path) && lower_extension(path) == ".tar") {
    Manifest m;
    m.shards.push_back({path, -1, 0, int64_t(fs::file_size(path))});
    return m;
  }
  if (!fs::is_directory(path)) throw IoError(path, "not found", "give a dataset folder (with manifest.json) or a .tar shard");
  Manifest m = read_manifest(path);
  if (m.shards.empty() || m.samples() == 0)
    throw InvalidInput(path, "the dataset is empty (no samples in manifest.json)", "generate data into it first");
  return m;
}

std::string shard_path(const std::string& dataset, const ShardInfo& shard) {
  return fs::is_regular_file(dataset) ? dataset : dataset + "/" + shard.name;
}

}  // namespace bareskin::shards
