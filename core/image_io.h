// Image files through OpenImageIO: PNG, JPEG, TIFF (8/16-bit), EXR (half/float, scanline or tiled, with mip levels).
#pragma once
#include <memory>
#include <optional>
#include <string>

#include "core/image.h"
#include "core/png_encoding.h"

namespace bareskin {

struct ImageFileInfo {
  int width = 0, height = 0, channels = 0;
  PixelType type = PixelType::UInt8;
  ColorSpace color_space = ColorSpace::sRGB;
  bool tiled = false;
  int mip_levels = 1;
  std::string format;  // "png", "openexr", ...
};

// Header only: size, storage type, colour space. IoError/InvalidInput like read_image.
ImageFileInfo probe_image(const std::string& path);

// Reads the top mip level as float. Integer files are scaled to [0,1]. The colour space comes from the file's tag
// (8/16-bit files without one are sRGB, float files linear) unless `assume` overrides it, e.g. Data for normal maps.
// Throws IoError (missing/unreadable) or InvalidInput (truncated, corrupt, not an image), naming the file.
Image read_image(const std::string& path, std::optional<ColorSpace> assume = std::nullopt);

struct ImageWriteOptions {
  std::optional<PixelType> type;  // default: uint8 for PNG/JPEG, uint16 for TIFF, half for EXR
  bool tiled = false;             // EXR/TIFF: 64x64 tiles
  bool mipmap = false;            // EXR/TIFF: full mip chain (implies tiled)
  std::string compression;        // EXR/TIFF: e.g. "zip", "piz", "dwaa"; empty: the format's default (EXR: zip)
  int jpeg_quality = 95;          // JPEG: 1-100
  // PNG: zlib level and row filters. The default is the project's one PNG encoding (core/png_encoding.h), the one
  // encode_png uses too, so a PNG written here and one encoded in memory from the same pixels are written alike.
  PngEncoding png;
  void check() const;  // InvalidInput naming the option
};

// Writes atomically; pixel values are stored as given (convert with to_srgb/to_linear first) and the file is tagged
// with the image's colour space. Integer outputs clamp to [0,1].
void write_image(const std::string& path, const Image& image, const ImageWriteOptions& options = {});

// Writes a scanline image a band of rows at a time, so that maps of any size (16K and beyond) never sit in memory
// whole. Same storage rules as write_image; the file appears only on commit() (atomic), never half-written.
class ImageStreamWriter {
 public:
  ImageStreamWriter(const std::string& path, int width, int height, int channels, ColorSpace space,
                    const ImageWriteOptions& options = {});
  ~ImageStreamWriter();
  ImageStreamWriter(ImageStreamWriter&&) noexcept;
  // Rows [y_begin, y_end), top to bottom, interleaved float; bands must come in order.
  void write_rows(int y_begin, int y_end, const float* pixels);
  void commit();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Reads a scanline or tiled image a band of rows at a time (top mip level, as float), so that 16K maps never sit in
// memory whole. The colour space is the file's (see read_image) unless `assume` overrides it.
class ImageStreamReader {
 public:
  explicit ImageStreamReader(const std::string& path, std::optional<ColorSpace> assume = std::nullopt);
  ~ImageStreamReader();
  const ImageFileInfo& info() const;
  // Rows [y_begin, y_end) into `pixels` (width * rows * channels floats). InvalidInput naming the file when the rows
  // cannot be decoded (truncated file) or hold NaN/Inf.
  void read_rows(int y_begin, int y_end, float* pixels);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace bareskin
