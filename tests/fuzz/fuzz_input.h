// What the fuzz targets share: the input as text, split into parts at NUL bytes (several files in one input), and a
// per-process scratch file for readers that take a path.
#pragma once
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace bareskin::fuzz {

inline std::string text(const uint8_t* data, size_t size) { return std::string(reinterpret_cast<const char*>(data), size); }

// The input cut at its first `count - 1` NUL bytes; missing parts are empty.
inline std::vector<std::string> parts(const std::string& input, size_t count) {
  std::vector<std::string> out;
  size_t begin = 0;
  while (out.size() + 1 < count) {
    const size_t nul = input.find('\0', begin);
    if (nul == std::string::npos) break;
    out.push_back(input.substr(begin, nul - begin));
    begin = nul + 1;
  }
  out.push_back(begin <= input.size() ? input.substr(begin) : std::string());
  out.resize(count);
  return out;
}

// Writes `bytes` to a file of this process under $TMPDIR (or /tmp) with `extension`, and returns its path.
inline std::string scratch_file(const std::string& bytes, const std::string& extension) {
  const char* dir = std::getenv("TMPDIR");
  const std::string path = std::string(dir && *dir ? dir : "/tmp") + "/bareskin_fuzz_" + std::to_string(getpid()) + extension;
  FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), f) != bytes.size()) std::abort();
  std::fclose(f);
  return path;
}

}  // namespace bareskin::fuzz
