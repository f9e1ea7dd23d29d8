#include "core/mesh_cache.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <optional>

#include "core/error.h"
#include "core/files.h"
#include "core/hash.h"
#include "core/log.h"
#include "core/mesh_io.h"

namespace bareskin {
namespace {

// Bump when read_mesh's result for some file changes (mesh_io.cc), so that older copies are ignored.
constexpr uint32_t kReaderVersion = 1;
constexpr char kMagic[8] = {'B', 'S', 'M', 'E', 'S', 'H', 'C', '\n'};
constexpr uint32_t kByteOrder = 0x01020304;  // read back as written only on a machine of the same byte order

// The file: this header, then V, F, UV, FUV, N as Eigen stores them (column after column; doubles and 32-bit ints),
// then the FNV-1a hash of everything before it.
struct Header {
  char magic[8];
  uint32_t version, byte_order;
  uint64_t source_size, source_hash;  // of the mesh file's bytes
  int64_t rows[5];                    // of V, F, UV, FUV, N
};
static_assert(sizeof(Header) == 8 + 4 + 4 + 8 + 8 + 5 * 8, "no padding in the header");

// A file's bytes, mapped read-only with its pages loaded in one call: reading a 14 MB OBJ into a fresh string costs a
// page fault per 4 KB on our VMs, more than the hash. Empty when the file cannot be opened or mapped.
class MappedFile {
 public:
  explicit MappedFile(const std::string& path) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return;
    struct stat st;
    if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
      void* p = ::mmap(nullptr, size_t(st.st_size), PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
      if (p != MAP_FAILED) data_ = static_cast<const char*>(p), size_ = size_t(st.st_size);
    }
    ::close(fd);
  }
  ~MappedFile() {
    if (data_) ::munmap(const_cast<char*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  const char* data() const { return data_; }
  size_t size() const { return size_; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
};

// A hash of bytes: FNV-1a over 8-byte words, then the tail byte by byte (a byte-wise FNV-1a costs 20 ms over a
// 65k-vertex OBJ; this a few).
uint64_t hash_bytes(const char* data, size_t size) {
  uint64_t h = kFnv1aBasis;
  const size_t words = size / 8;
  for (size_t i = 0; i < words; ++i) {
    uint64_t w;
    std::memcpy(&w, data + 8 * i, 8);
    h = (h ^ w) * 1099511628211ull;
  }
  return fnv1a(data + 8 * words, size - 8 * words, h);
}

struct Source {
  uint64_t size, hash;
};

template <typename Matrix>
void append(std::string& out, const Matrix& m) {
  out.append(reinterpret_cast<const char*>(m.data()), size_t(m.size()) * sizeof(typename Matrix::Scalar));
}

std::string encode(const Mesh& mesh, const Source& source) {
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof(kMagic));
  h.version = kReaderVersion;
  h.byte_order = kByteOrder;
  h.source_size = source.size;
  h.source_hash = source.hash;
  const int64_t rows[5] = {mesh.V.rows(), mesh.F.rows(), mesh.UV.rows(), mesh.FUV.rows(), mesh.N.rows()};
  std::memcpy(h.rows, rows, sizeof(rows));
  std::string out(reinterpret_cast<const char*>(&h), sizeof(h));
  append(out, mesh.V);
  append(out, mesh.F);
  append(out, mesh.UV);
  append(out, mesh.FUV);
  append(out, mesh.N);
  const uint64_t check = hash_bytes(out.data(), out.size());
  out.append(reinterpret_cast<const char*>(&check), sizeof(check));
  return out;
}

template <typename Matrix>
void take(const char* bytes, size_t& at, int64_t rows, Matrix& m) {
  m.resize(rows, Matrix::ColsAtCompileTime);
  const size_t n = size_t(m.size()) * sizeof(typename Matrix::Scalar);
  std::memcpy(m.data(), bytes + at, n);
  at += n;
}

// The mesh of `cache` when it is a whole copy, of this reader version, of the file `source` describes.
std::optional<Mesh> decode(const MappedFile& cache, const Source& source, const std::string& path) {
  Header h;
  if (cache.size() < sizeof(h) + sizeof(uint64_t)) return std::nullopt;
  std::memcpy(&h, cache.data(), sizeof(h));
  if (std::memcmp(h.magic, kMagic, sizeof(kMagic)) != 0 || h.version != kReaderVersion || h.byte_order != kByteOrder ||
      h.source_size != source.size || h.source_hash != source.hash)
    return std::nullopt;
  const size_t columns[5] = {3, 3, 2, 3, 3}, scalar[5] = {8, 4, 8, 4, 8};
  uint64_t expected = sizeof(h) + sizeof(uint64_t);
  for (int k = 0; k < 5; ++k) {
    if (h.rows[k] < 0 || h.rows[k] > (int64_t(1) << 31)) return std::nullopt;
    expected += uint64_t(h.rows[k]) * columns[k] * scalar[k];
  }
  if (expected != cache.size()) return std::nullopt;
  uint64_t check;
  std::memcpy(&check, cache.data() + cache.size() - sizeof(check), sizeof(check));
  if (check != hash_bytes(cache.data(), cache.size() - sizeof(check))) return std::nullopt;
  Mesh mesh;
  size_t at = sizeof(h);
  take(cache.data(), at, h.rows[0], mesh.V);
  take(cache.data(), at, h.rows[1], mesh.F);
  take(cache.data(), at, h.rows[2], mesh.UV);
  take(cache.data(), at, h.rows[3], mesh.FUV);
  take(cache.data(), at, h.rows[4], mesh.N);
  try {
    validate(mesh, path);  // the checksum holds, so only a copy written wrongly could fail here
  } catch (const InvalidInput&) {
    return std::nullopt;
  }
  return mesh;
}

}  // namespace

std::string mesh_cache_path(const std::string& path) { return path + ".cache"; }

Mesh read_mesh_cached(const std::string& path, MeshCacheUse* use) {
  MeshCacheUse ignored;
  MeshCacheUse& said = use ? *use : ignored;
  const auto source_of = [&]() -> std::optional<Source> {
    const MappedFile file(path);
    if (!file.data()) return std::nullopt;
    return Source{file.size(), hash_bytes(file.data(), file.size())};
  };
  const std::optional<Source> source = source_of();
  if (!source) return read_mesh(path);  // missing, unreadable, empty, a folder: read_mesh names the problem
  const std::string cache_path = mesh_cache_path(path);
  if (const MappedFile cache(cache_path); cache.data()) {
    if (std::optional<Mesh> mesh = decode(cache, *source, path)) {
      said = MeshCacheUse::kHit;
      return std::move(*mesh);
    }
    spdlog::debug("{}: not the mesh of {} (changed, older or corrupt): reading the file", cache_path, path);
  }
  Mesh mesh = read_mesh(path);
  said = MeshCacheUse::kNotWritten;
  try {
    // Only when the file is still what was hashed (another process may have replaced it meanwhile).
    const std::optional<Source> after = source_of();
    if (after && after->size == source->size && after->hash == source->hash) {
      write_file_atomic(cache_path, encode(mesh, *source));
      said = MeshCacheUse::kWritten;
    }
  } catch (const std::exception& e) {
    spdlog::debug("{}: no mesh cache written: {}", cache_path, e.what());
  }
  return mesh;
}

}  // namespace bareskin
