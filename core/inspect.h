// `bareskin inspect`: what a file holds — a mesh (counts, UV seams, boundary, area, bounds), an image (format, size,
// channels, pixel type, colour space, tiling, mips; decoded to catch truncation), a safetensors file (metadata, each
// tensor's dtype and shape, optionally min/max/mean and every value) or a landmark file — as JSON or text.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

namespace bareskin {

// The file's description by its extension (.obj/.ply mesh, .safetensors, .json/.pts landmarks, else an image).
// `stats`: tensor min/max/mean; `values`: every tensor element in row-major order. The readers' InvalidInput / IoError
// for a file that is not what its extension says.
nlohmann::json inspect_file(const std::string& path, bool stats, bool values);
// The same as indented text lines ("file: kind", then "  key: value" and one line per tensor).
std::string inspect_text(const nlohmann::json& description);

}  // namespace bareskin
