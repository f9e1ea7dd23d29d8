// PNG in memory through libpng: the codec of dataset shards, which the Torch side must read where OpenImageIO is
// absent (the GPU machine). 8- and 16-bit grey, grey+alpha, RGB and RGBA; values as floats in [0, 1], no transfer
// function applied (the caller knows whether a member is sRGB colour or data).
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>

#include "core/image.h"

namespace bareskin {

// Refuses (InvalidInput naming `source`, `fix` as what to do) a PNG of `size` bytes one of whose chunks runs past the
// end of the file, the last chunk's bare 8-byte header included, before libpng allocates what a chunk's length says
// (ours here, OpenImageIO's in read_image). `header(at)` returns the 8 bytes at offset `at` (length and type).
using PngChunkHeader = std::array<unsigned char, 8>;
void check_png_chunks(uint64_t size, const std::function<PngChunkHeader(uint64_t)>& header, const std::string& source,
                      const std::string& fix);

// Decodes PNG bytes. `source` names the file or shard member in the error (InvalidInput) for corrupt data.
Image decode_png(const std::string& bytes, const std::string& source);

// Encodes 1-4 channels at 8 or 16 bits, values clamped to [0, 1] and rounded, with the project's PNG encoding
// (core/png_encoding.h).
std::string encode_png(const Image& image, int bits = 8);

}  // namespace bareskin
