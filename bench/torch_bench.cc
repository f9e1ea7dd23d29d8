// torch_bench: the Torch-side bench programs in one binary. Run under one of their names (bin/ holds a link per
// program: render_torch_bench, detect_bench, ...), or as `torch_bench NAME ARGS...`. One binary because every Torch
// translation unit pays ~15 CPU-s of LibTorch's precompiled header on 2 cores, and the programs share their templates.
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>

namespace {

using Main = int (*)(int, char**);
struct Program {
  const char* name;
  Main main;
};

}  // namespace

#define BARESKIN_BENCH(NAME, NS) \
  namespace NS {                 \
  int main(int, char**);         \
  }
#include "bench/torch_bench_list.h"
#undef BARESKIN_BENCH

int main(int argc, char** argv) {
  static const Program programs[] = {
#define BARESKIN_BENCH(NAME, NS) {#NAME, NS::main},
#include "bench/torch_bench_list.h"
#undef BARESKIN_BENCH
  };
  std::string name = argv[0];
  if (const size_t slash = name.rfind('/'); slash != std::string::npos) name = name.substr(slash + 1);
  if (name == "torch_bench" && argc > 1) {
    name = argv[1];
    ++argv;
    --argc;
  }
  for (const Program& p : programs) {
    if (name != p.name) continue;
    try {
      return p.main(argc, argv);
    } catch (const std::exception& e) {  // a bad argument (a missing file, ...) is one line, not an abort
      std::fprintf(stderr, "%s: %s\n", p.name, e.what());
      return 3;
    }
  }
  std::fprintf(stderr, "torch_bench: no bench program named '%s'; run one of:", name.c_str());
  for (const Program& p : programs) std::fprintf(stderr, " %s", p.name);
  std::fprintf(stderr, "\n");
  return 2;
}
