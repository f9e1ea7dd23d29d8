#include "core/mesh_cache.h"

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <optional>
#include <vector>

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

// FNV-1a over 8-byte words, then the last bytes one by one (a byte-wise FNV-1a costs 20 ms over a 65k-vertex OBJ;
// this a few), fed in pieces of any size: the result is that of the bytes end to end.
class WordHash {
 public:
  void add(const char* p, size_t n) {
    while (n > 0 && pending_size_ > 0) {  // complete the word started by the last piece
      pending_[pending_size_++] = *p++;
      --n;
      if (pending_size_ == 8) {
        mix(pending_);
        pending_size_ = 0;
      }
    }
    for (; n >= 8; p += 8, n -= 8) mix(p);
    std::memcpy(pending_, p, n);
    pending_size_ = n;
  }
  uint64_t value() const { return fnv1a(pending_, pending_size_, h_); }

 private:
  void mix(const char* p) {
    uint64_t w;
    std::memcpy(&w, p, 8);
    h_ = (h_ ^ w) * 1099511628211ull;
  }
  uint64_t h_ = kFnv1aBasis;
  char pending_[8];
  size_t pending_size_ = 0;
};

struct Source {
  uint64_t size, hash;
};

// The size and hash of the file at `path`, read in 1 MB pieces (a 14 MB OBJ read into one fresh buffer costs a page
// fault per 4 KB on our VMs, more than the hash); nothing when it is no regular file or cannot be read whole.
std::optional<Source> source_of(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::is_regular_file(path, ec) ? std::filesystem::file_size(path, ec) : 0;
  std::ifstream in(path, std::ios::binary);
  if (ec || size == 0 || !in) return std::nullopt;
  std::vector<char> piece(size_t(1) << 20);
  WordHash hash;
  uint64_t read = 0;
  while (in.read(piece.data(), std::streamsize(piece.size())) || in.gcount() > 0) {
    hash.add(piece.data(), size_t(in.gcount()));
    read += uint64_t(in.gcount());
  }
  if (read != size) return std::nullopt;  // it changed while being read
  return Source{size, hash.value()};
}

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
  WordHash check_hash;
  check_hash.add(out.data(), out.size());
  const uint64_t check = check_hash.value();
  out.append(reinterpret_cast<const char*>(&check), sizeof(check));
  return out;
}

// Reads `rows` rows of `m` from `in` straight into the matrix, and hashes them.
template <typename Matrix>
bool take(std::ifstream& in, int64_t rows, Matrix& m, WordHash& hash) {
  m.resize(rows, Matrix::ColsAtCompileTime);
  const size_t n = size_t(m.size()) * sizeof(typename Matrix::Scalar);
  if (!in.read(reinterpret_cast<char*>(m.data()), std::streamsize(n))) return false;
  hash.add(reinterpret_cast<const char*>(m.data()), n);
  return true;
}

// The mesh of the cache file when it is a whole copy, of this reader version, of the file `source` describes.
std::optional<Mesh> decode(const std::string& cache_path, const Source& source, const std::string& path) {
  std::error_code ec;
  const uint64_t cache_size = std::filesystem::file_size(cache_path, ec);
  std::ifstream in(cache_path, std::ios::binary);
  Header h;
  if (ec || !in || cache_size < sizeof(h) + sizeof(uint64_t)) return std::nullopt;
  if (!in.read(reinterpret_cast<char*>(&h), sizeof(h))) return std::nullopt;
  if (std::memcmp(h.magic, kMagic, sizeof(kMagic)) != 0 || h.version != kReaderVersion || h.byte_order != kByteOrder ||
      h.source_size != source.size || h.source_hash != source.hash)
    return std::nullopt;
  const size_t columns[5] = {3, 3, 2, 3, 3}, scalar[5] = {8, 4, 8, 4, 8};
  uint64_t expected = sizeof(h) + sizeof(uint64_t);
  for (int k = 0; k < 5; ++k) {
    if (h.rows[k] < 0 || h.rows[k] > (int64_t(1) << 31)) return std::nullopt;
    expected += uint64_t(h.rows[k]) * columns[k] * scalar[k];
  }
  if (expected != cache_size) return std::nullopt;
  WordHash hash;
  hash.add(reinterpret_cast<const char*>(&h), sizeof(h));
  Mesh mesh;
  uint64_t check = 0;
  if (!take(in, h.rows[0], mesh.V, hash) || !take(in, h.rows[1], mesh.F, hash) || !take(in, h.rows[2], mesh.UV, hash) ||
      !take(in, h.rows[3], mesh.FUV, hash) || !take(in, h.rows[4], mesh.N, hash) ||
      !in.read(reinterpret_cast<char*>(&check), sizeof(check)) || check != hash.value())
    return std::nullopt;
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
  const std::optional<Source> source = source_of(path);
  if (!source) return read_mesh(path);  // missing, unreadable, empty, a folder: read_mesh names the problem
  const std::string cache_path = mesh_cache_path(path);
  std::error_code ec;
  if (std::filesystem::is_regular_file(cache_path, ec)) {
    if (std::optional<Mesh> mesh = decode(cache_path, *source, path)) {
      said = MeshCacheUse::kHit;
      return std::move(*mesh);
    }
    spdlog::debug("{}: not the mesh of {} (changed, older or corrupt): reading the file", cache_path, path);
  }
  Mesh mesh = read_mesh(path);
  said = MeshCacheUse::kNotWritten;
  try {
    // Only when the file is still what was hashed (another process may have replaced it meanwhile).
    const std::optional<Source> after = source_of(path);
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
