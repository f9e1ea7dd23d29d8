// A .glb read back and checked against glTF 2.0's binary layout (the avatar's GLB, or one a user brings): the header,
// the JSON and BIN chunks, every bufferView inside the BIN chunk, every accessor inside its bufferView, the first
// primitive's indices below its vertex count, every image inside its bufferView. No Torch; fuzzed (tests/fuzz).
#pragma once
#include <cstdint>
#include <string>
#include <vector>

namespace bareskin::texture {

struct GlbSummary {
  int64_t vertices = 0, triangles = 0;  // of the first mesh's first primitive
  std::vector<std::string> images;      // their names ("" where unnamed), in order
  std::string generator;                // asset.generator
};

// InvalidInput naming `source` for anything that breaks the layout: a wrong magic, version or length, chunks that
// overrun the file, JSON that is not an object, views or accessors outside their data, an index past the vertices.
GlbSummary read_glb(const std::string& bytes, const std::string& source);

}  // namespace bareskin::texture
