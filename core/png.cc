#include "core/png.h"
#include "core/png_encoding.h"

#include <png.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "core/error.h"
#include "core/memory_limit.h"

namespace bareskin {
namespace {

struct ReadCursor {
  const std::string* bytes;
  size_t offset;
};

void read_callback(png_structp png, png_bytep out, png_size_t length) {
  auto* cursor = static_cast<ReadCursor*>(png_get_io_ptr(png));
  if (cursor->offset + length > cursor->bytes->size()) png_error(png, "truncated data");
  std::memcpy(out, cursor->bytes->data() + cursor->offset, length);
  cursor->offset += length;
}

void write_callback(png_structp png, png_bytep data, png_size_t length) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<const char*>(data), length);
}

// libpng reports errors by longjmp; turn its message into an exception after the jump.
void error_callback(png_structp png, png_const_charp message) {
  auto* text = static_cast<std::string*>(png_get_error_ptr(png));
  *text = message;
  png_longjmp(png, 1);
}
void warning_callback(png_structp, png_const_charp) {}

}  // namespace

// Every chunk's length must fit in the file before libpng sees it: libpng allocates (and ASan clears) what a chunk's
// length says, and a hostile tEXt length of 700 MB took seconds per file (found by tests/fuzz/fuzz_png). That holds
// for the last chunk too: a bare 8-byte header at the end of the file (no data, no CRC) with a 2 GB tEXt length made
// libpng allocate 2.3 GB, ours and OpenImageIO's alike (found by the fuzzer in CI).
void check_png_chunks(uint64_t size, const std::function<PngChunkHeader(uint64_t)>& header, const std::string& source,
                      const std::string& fix) {
  uint64_t at = 8;
  while (at + 8 <= size) {  // a header is there: its data and CRC must be too
    const PngChunkHeader h = header(at);
    const uint64_t length = (uint64_t(h[0]) << 24) | (uint64_t(h[1]) << 16) | (uint64_t(h[2]) << 8) | h[3];
    const std::string type(reinterpret_cast<const char*>(h.data()) + 4, 4);
    if (at + 12 > size || length > size - at - 12)
      throw InvalidInput(source, "corrupt PNG (chunk '" + type + "' of " + std::to_string(length) +
                                     " bytes runs past the end of the file)", fix);
    if (type == "IEND") return;
    at += 12 + length;
  }
}

Image decode_png(const std::string& bytes, const std::string& source) {
  if (bytes.size() < 8 || png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) != 0)
    throw InvalidInput(source, "not a PNG image", "rewrite the file or regenerate the shard");
  check_png_chunks(
      bytes.size(),
      [&](uint64_t at) {
        PngChunkHeader h;
        std::memcpy(h.data(), bytes.data() + at, h.size());
        return h;
      },
      source, "rewrite the file or regenerate the shard");
  std::string message;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &message, error_callback, warning_callback);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    throw std::bad_alloc();
  }
  Image image;
  std::vector<unsigned char> data;
  std::vector<png_bytep> rows;
  ReadCursor cursor{&bytes, 0};
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw InvalidInput(source, "corrupt PNG (" + message + ")", "rewrite the file or regenerate the shard");
  }
  png_set_read_fn(png, &cursor, read_callback);
  png_read_info(png, info);
  png_set_expand(png);  // palette -> RGB, low-bit grey -> 8 bits, tRNS -> alpha
  const int bits = png_get_bit_depth(png, info) == 16 ? 16 : 8;
  if (bits == 16) png_set_swap(png);  // host (little-endian) order
  png_read_update_info(png, info);
  image.width = int(png_get_image_width(png, info));
  image.height = int(png_get_image_height(png, info));
  image.channels = int(png_get_channels(png, info));
  image.color_space = ColorSpace::Data;
  const size_t stride = png_get_rowbytes(png, info);
  try {  // the header's promise, checked before anything is allocated (core/memory_limit.h)
    check_memory(source, double(stride) * image.height + 4.0 * image.width * image.height * image.channels,
                 std::to_string(image.width) + "x" + std::to_string(image.height) + " PNG");
  } catch (...) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw;
  }
  data.resize(stride * image.height);
  rows.resize(image.height);
  for (int y = 0; y < image.height; ++y) rows[y] = data.data() + y * stride;
  png_read_image(png, rows.data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);

  const size_t count = size_t(image.width) * image.height * image.channels;
  image.pixels.resize(count);
  if (bits == 16) {
    for (int y = 0; y < image.height; ++y) {
      const auto* row = reinterpret_cast<const uint16_t*>(data.data() + y * stride);
      for (size_t i = 0; i < size_t(image.width) * image.channels; ++i)
        image.pixels[y * size_t(image.width) * image.channels + i] = row[i] / 65535.f;
    }
  } else {
    for (int y = 0; y < image.height; ++y)
      for (size_t i = 0; i < size_t(image.width) * image.channels; ++i)
        image.pixels[y * size_t(image.width) * image.channels + i] = data[y * stride + i] / 255.f;
  }
  return image;
}

void PngEncoding::check() const {
  if (level < 0 || level > 9)
    throw InvalidInput("png level", "must be in [0, 9] (got " + std::to_string(level) + ")", "zlib's levels; 3 is ours");
}

std::string encode_png(const Image& image, int bits) { return encode_png(image, bits, PngEncoding{}); }

std::string encode_png(const Image& image, int bits, const PngEncoding& encoding) {
  BS_CHECK(image.channels >= 1 && image.channels <= 4, "PNG holds 1-4 channels");
  BS_CHECK(bits == 8 || bits == 16, "PNG bit depth is 8 or 16");
  std::vector<unsigned char> data(image.pixels.size() * size_t(bits / 8));
  const float scale = bits == 16 ? 65535.f : 255.f;
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    const float v = image.pixels[i];
    const auto q = static_cast<uint32_t>(std::lround((std::isfinite(v) ? std::clamp(v, 0.f, 1.f) : 0.f) * scale));
    if (bits == 16) {  // PNG stores big-endian samples
      data[2 * i] = static_cast<unsigned char>(q >> 8);
      data[2 * i + 1] = static_cast<unsigned char>(q & 0xff);
    } else {
      data[i] = static_cast<unsigned char>(q);
    }
  }
  return encode_png_samples(data.data(), image.width, image.height, image.channels, bits, encoding);
}

std::string encode_png_samples(const unsigned char* data, int width, int height, int channels, int bits,
                               const PngEncoding& encoding) {
  BS_CHECK(channels >= 1 && channels <= 4, "PNG holds 1-4 channels");
  BS_CHECK(bits == 8 || bits == 16, "PNG bit depth is 8 or 16");
  encoding.check();
  static const int kColorType[] = {PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA, PNG_COLOR_TYPE_RGB,
                                   PNG_COLOR_TYPE_RGBA};
  const size_t row_bytes = size_t(width) * size_t(channels) * size_t(bits / 8);
  std::string out, message;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &message, error_callback, warning_callback);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw std::bad_alloc();
  }
  std::vector<png_bytep> rows(static_cast<size_t>(height));
  for (int y = 0; y < height; ++y) rows[size_t(y)] = const_cast<png_bytep>(data + size_t(y) * row_bytes);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw InternalError("PNG encoding failed: " + message);
  }
  png_set_write_fn(png, &out, write_callback, nullptr);
  png_set_IHDR(png, info, width, height, bits, kColorType[channels - 1], PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_compression_level(png, encoding.level);
  if (encoding.fast) {
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_strategy(png, Z_RLE);
  }
  png_write_info(png, info);
  png_write_image(png, rows.data());
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

}  // namespace bareskin
