// The memory a file may ask for. Headers of images and archives state sizes (a PNG's width and height, a tar member's
// length) that a reader would allocate before reading the data; a hostile or corrupt file can promise terabytes. Every
// such reader checks the promise here first and refuses it with one line, before allocating.
// The limit: `--max-memory` (apps/cli.cc), else the environment's BARESKIN_MAX_MEMORY, else 8 GB. Values are bytes
// with an optional K, M, G or T suffix (powers of 1000): "8G", "512M", "1500000".
#pragma once
#include <cstdint>
#include <string>

namespace bareskin {

constexpr int64_t kDefaultMaxMemory = int64_t(8) * 1000 * 1000 * 1000;

// The limit in bytes.
int64_t max_memory();
// Sets it for this process (the --max-memory flag). InvalidInput for a value that is not a positive size.
void set_max_memory(const std::string& value);
// "8G" -> 8e9. InvalidInput naming `what` unless a positive integer with an optional K/M/G/T suffix.
int64_t parse_memory_size(const std::string& value, const std::string& what);

// InvalidInput naming `source` when `bytes` (a double, so that a product of header fields cannot overflow) exceeds
// the limit: "<what> needs <n> GB, more than the memory limit of <m> GB; ...".
void check_memory(const std::string& source, double bytes, const std::string& what);

}  // namespace bareskin
