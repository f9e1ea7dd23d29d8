// libFuzzer target: a mesh file through read_mesh (OpenMesh behind our checks): PLY when the input starts with "ply",
// else OBJ. Reads a consistent mesh or raises InvalidInput.
#include <cstdlib>

#include "core/error.h"
#include "core/mesh_io.h"
#include "tests/fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  setenv("BARESKIN_MAX_MEMORY", "64M", 1);  // what a PLY header's counts may ask for; ASan's default limit is 2 GB
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string input = bareskin::fuzz::text(data, size);
  const bool ply = input.compare(0, 3, "ply") == 0;
  try {
    const bareskin::Mesh mesh = bareskin::read_mesh(bareskin::fuzz::scratch_file(input, ply ? ".ply" : ".obj"));
    const auto nv = mesh.V.rows();
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
      for (int k = 0; k < 3; ++k)
        if (mesh.F(f, k) < 0 || mesh.F(f, k) >= nv) std::abort();  // a face names a vertex that is not there
  } catch (const bareskin::InvalidInput&) {
  }
  return 0;
}
