// PNG in memory through libpng: the codec of dataset shards, which the Torch side must read where OpenImageIO is
// absent (the GPU machine). 8- and 16-bit grey, grey+alpha, RGB and RGBA; values as floats in [0, 1], no transfer
// function applied (the caller knows whether a member is sRGB colour or data).
#pragma once
#include <string>

#include "core/image.h"

namespace bareskin {

// Decodes PNG bytes. `source` names the file or shard member in the error (InvalidInput) for corrupt data.
Image decode_png(const std::string& bytes, const std::string& source);

// Encodes 1-4 channels at 8 or 16 bits, values clamped to [0, 1] and rounded, with the project's PNG encoding
// (core/png_encoding.h).
std::string encode_png(const Image& image, int bits = 8);

}  // namespace bareskin
