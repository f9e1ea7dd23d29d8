// libFuzzer target: a dataset shard (tar) read sample by sample, or a manifest.json (input starting with '{'). Either
// parses or raises InvalidInput; the reader never allocates more than the memory limit a header promises.
#include <cstdlib>

#include "core/error.h"
#include "core/memory_limit.h"
#include "core/shards.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("BARESKIN_MAX_MEMORY", "64M", 1);  // a member may promise at most this; ASan's default limit is 2 GB
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input = bareskin::fuzz::text(data, size);
  try {
    if (!input.empty() && input[0] == '{') {
      bareskin::shards::parse_manifest(input, "fuzz/manifest.json");
      return 0;
    }
    bareskin::shards::ShardReader reader(bareskin::fuzz::scratch_file(input, ".tar"));
    bareskin::shards::Sample sample;
    while (reader.next(sample)) {
      if (sample.key.empty() || sample.members.empty()) std::abort();
    }
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
