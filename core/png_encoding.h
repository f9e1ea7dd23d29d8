// The project's PNG encoding: encode_png's (core/png.h) and write_image's (core/image_io.h, ImageWriteOptions::png).
#pragma once
#include <string>

#include "core/image.h"

namespace bareskin {

// The default, `fast`: one fixed row filter (Sub) and zlib's run-length strategy. Against libpng's per-row filter
// search with zlib's default strategy (`fast` false), measured on 1K UV maps (noise and realistic), a 512² preview, a
// 1024² render and a contact sheet: 2.5-4.5x faster to encode, and files 5-13 % smaller (colour maps, renders) to
// 1-9 % larger (grey roughness maps) than level 3's; against level 6 with the search (OpenImageIO's own default, which
// write_image used before), 2-10x faster, files -2 % to +6 % the size (+33 % for a smooth grey roughness map). The level hardly matters with `fast` (run-length matches only). bench/BENCHMARKS.md.
struct PngEncoding {
  int level = 3;      // zlib's 0 (stored) to 9 (smallest)
  bool fast = true;   // false: libpng's per-row filter search, zlib's default strategy
  void check() const;  // InvalidInput for a level outside [0, 9]
};

// encode_png (core/png.h) with `encoding`; the default encoding gives encode_png's bytes.
std::string encode_png(const Image& image, int bits, const PngEncoding& encoding);

// The same from samples already quantised: width × height × channels values of `bits` bits, row by row (16-bit
// big-endian), as encode_png would have made them.
std::string encode_png_samples(const unsigned char* data, int width, int height, int channels, int bits,
                               const PngEncoding& encoding);

}  // namespace bareskin
