// PNG encoding with a chosen speed/size trade (core/png.h's encode_png uses the default: zlib level 3 and libpng's
// per-row filter search). For writers of large members, such as make-dataset's 4K target maps.
#pragma once
#include <string>

#include "core/image.h"

namespace bareskin {

// `fast`: one fixed row filter (Sub) and zlib's run-length strategy instead of the per-row filter search: about 3x
// faster and ~10 % smaller on UV maps (measured on 1K diffuse and normal maps); other bytes than the default.
struct PngEncoding {
  int level = 3;
  bool fast = false;
};

// encode_png (core/png.h) with `encoding`; the default encoding gives encode_png's bytes.
std::string encode_png(const Image& image, int bits, const PngEncoding& encoding);

// The same from samples already quantised: width × height × channels values of `bits` bits, row by row (16-bit
// big-endian), as encode_png would have made them.
std::string encode_png_samples(const unsigned char* data, int width, int height, int channels, int bits,
                               const PngEncoding& encoding);

}  // namespace bareskin
