#include "core/memory_limit.h"

#include <atomic>
#include <cctype>
#include <cstdio>
#include <cstdlib>

#include "core/error.h"

namespace bareskin {
namespace {

std::atomic<int64_t> g_limit{-1};  // -1: not set by a flag

int64_t from_environment() {
  const char* env = std::getenv("BARESKIN_MAX_MEMORY");
  if (!env || !*env) return kDefaultMaxMemory;
  return parse_memory_size(env, "BARESKIN_MAX_MEMORY");
}

std::string gigabytes(double bytes) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g GB", bytes / 1e9);
  return text;
}

}  // namespace

int64_t parse_memory_size(const std::string& value, const std::string& what) {
  const auto bad = [&]() -> int64_t {
    throw InvalidInput(what, "'" + value + "' is not a memory size", "give bytes with an optional K, M, G or T suffix, e.g. 8G");
  };
  size_t digits = 0;
  while (digits < value.size() && std::isdigit(static_cast<unsigned char>(value[digits]))) ++digits;
  if (digits == 0 || digits > 15) return bad();
  int64_t bytes = std::stoll(value.substr(0, digits));
  const std::string suffix = value.substr(digits);
  if (suffix.size() > 1) return bad();
  if (!suffix.empty()) {
    const char* units = "KMGT";
    int64_t scale = 1000;
    const char u = char(std::toupper(static_cast<unsigned char>(suffix[0])));
    for (const char* p = units; *p && *p != u; ++p) scale *= 1000;
    if (scale > int64_t(1000) * 1000 * 1000 * 1000 || bytes > (int64_t(1) << 62) / scale) return bad();
    bytes *= scale;
  }
  if (bytes <= 0) return bad();
  return bytes;
}

int64_t max_memory() {
  const int64_t set = g_limit.load();
  return set > 0 ? set : from_environment();
}

void set_max_memory(const std::string& value) { g_limit = parse_memory_size(value, "--max-memory"); }

void check_memory(const std::string& source, double bytes, const std::string& what) {
  const int64_t limit = max_memory();
  if (!(bytes <= double(limit)))
    throw InvalidInput(source, what + " needs " + gigabytes(bytes) + ", more than the memory limit of " + gigabytes(double(limit)),
                       "the file is corrupt or hostile; if it is real, raise --max-memory (or BARESKIN_MAX_MEMORY)");
}

}  // namespace bareskin
