#include "core/image_io.h"

#include <OpenImageIO/imageio.h>
#include <png.h>

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>

#include "core/files.h"
#include "core/error.h"
#include "core/memory_limit.h"
#include "core/png.h"

namespace bareskin {
namespace {

PixelType pixel_type(OIIO::TypeDesc t) {
  switch (t.basetype) {
    case OIIO::TypeDesc::UINT8:
    case OIIO::TypeDesc::INT8: return PixelType::UInt8;
    case OIIO::TypeDesc::UINT16:
    case OIIO::TypeDesc::INT16: return PixelType::UInt16;
    case OIIO::TypeDesc::HALF: return PixelType::Half;
    default: return PixelType::Float;
  }
}

OIIO::TypeDesc oiio_type(PixelType t) {
  switch (t) {
    case PixelType::UInt8: return OIIO::TypeDesc::UINT8;
    case PixelType::UInt16: return OIIO::TypeDesc::UINT16;
    case PixelType::Half: return OIIO::TypeDesc::HALF;
    case PixelType::Float: return OIIO::TypeDesc::FLOAT;
  }
  return OIIO::TypeDesc::FLOAT;
}

ColorSpace color_space_of(const OIIO::ImageSpec& spec) {
  const std::string tag = spec.get_string_attribute("oiio:ColorSpace");
  if (OIIO::Strutil::iequals(tag, "srgb")) return ColorSpace::sRGB;
  if (OIIO::Strutil::iequals(tag, "raw") || OIIO::Strutil::iequals(tag, "data")) return ColorSpace::Data;
  if (OIIO::Strutil::iequals(tag, "linear") || OIIO::Strutil::istarts_with(tag, "lin")) return ColorSpace::Linear;
  return pixel_type(spec.format) == PixelType::UInt8 || pixel_type(spec.format) == PixelType::UInt16 ? ColorSpace::sRGB
                                                                                                     : ColorSpace::Linear;
}

// OpenImageIO's messages can span lines; ours are one line.
std::string one_line(std::string message) {
  std::replace(message.begin(), message.end(), '\n', ' ');
  return message;
}

[[noreturn]] void write_failed(const std::string& path, const std::string& why) {
  throw IoError(path, "cannot write image (" + one_line(why) + ")", "check free disk space and permissions");
}

// libpng prints its own "libpng error: ..." to stderr before OpenImageIO reports the same fault to us. While any PNG
// is being decoded, stderr points at /dev/null (reference-counted, so parallel decodes do not serialise); the error
// still reaches the user, once, through our exception.
class SilencedStderr {
 public:
  explicit SilencedStderr(bool active) : active_(active) {
    if (!active_) return;
    std::lock_guard<std::mutex> lock(mutex());
    if (count()++ == 0) {
      saved() = ::dup(STDERR_FILENO);
      const int null = ::open("/dev/null", O_WRONLY);
      if (null >= 0) {
        ::dup2(null, STDERR_FILENO);
        ::close(null);
      }
    }
  }
  ~SilencedStderr() {
    if (!active_) return;
    std::lock_guard<std::mutex> lock(mutex());
    if (--count() == 0 && saved() >= 0) {
      ::dup2(saved(), STDERR_FILENO);
      ::close(saved());
    }
  }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static int& count() {
    static int c = 0;
    return c;
  }
  static int& saved() {
    static int fd = -1;
    return fd;
  }
  bool active_;
};

// A PNG's chunk lengths checked against the file's size before OpenImageIO's libpng allocates them (core/png.h).
void check_png_file(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  char signature[8] = {};
  if (!file.read(signature, 8) || png_sig_cmp(reinterpret_cast<png_const_bytep>(signature), 0, 8) != 0) return;
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  if (ec) return;  // OpenImageIO reports what it cannot read
  check_png_chunks(
      size,
      [&](uint64_t at) {
        PngChunkHeader h{};
        file.seekg(std::streamoff(at));
        file.read(reinterpret_cast<char*>(h.data()), std::streamsize(h.size()));
        if (!file) throw IoError(path, "cannot read the PNG chunk at byte " + std::to_string(at), "check the disk");
        return h;
      },
      path, "the file is truncated or corrupt: export it again");
}

std::unique_ptr<OIIO::ImageInput> open_input(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw IoError(path, "no such file", "check the path");
  if (std::filesystem::is_directory(path, ec)) throw IoError(path, "is a folder, not an image", "give an image file");
  check_png_file(path);
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    const std::string why = one_line(OIIO::geterror());
    throw InvalidInput(path, "cannot read image" + (why.empty() ? std::string() : " (" + why + ")"),
                       "the file is truncated, corrupt or not an image");
  }
  return in;
}


// 2x box downsample for mip levels (odd sizes round down, at least 1).
Image half_size(const Image& in) {
  Image out(std::max(1, in.width / 2), std::max(1, in.height / 2), in.channels, in.color_space);
  for (int y = 0; y < out.height; ++y) {
    for (int x = 0; x < out.width; ++x) {
      for (int c = 0; c < in.channels; ++c) {
        float sum = 0;
        int n = 0;
        for (int dy = 0; dy < 2; ++dy) {
          for (int dx = 0; dx < 2; ++dx) {
            const int sx = std::min(in.width - 1, 2 * x + dx), sy = std::min(in.height - 1, 2 * y + dy);
            sum += in.at(sx, sy, c);
            ++n;
          }
        }
        out.at(x, y, c) = sum / n;
      }
    }
  }
  return out;
}

}  // namespace

ImageFileInfo probe_image(const std::string& path) {
  auto in = open_input(path);
  const OIIO::ImageSpec& spec = in->spec();
  ImageFileInfo info;
  info.width = spec.width;
  info.height = spec.height;
  info.channels = spec.nchannels;
  info.type = pixel_type(spec.format);
  info.color_space = color_space_of(spec);
  info.tiled = spec.tile_width > 0;
  info.format = in->format_name();
  while (in->seek_subimage(0, info.mip_levels)) ++info.mip_levels;
  return info;
}

Image read_image(const std::string& path, std::optional<ColorSpace> assume) {
  auto in = open_input(path);
  const OIIO::ImageSpec spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    throw InvalidInput(path, "image has no pixels", "the file is corrupt");
  }
  // The header's promise (float pixels), checked before allocating: core/memory_limit.h.
  check_memory(path, 4.0 * spec.width * spec.height * spec.nchannels,
               std::to_string(spec.width) + "x" + std::to_string(spec.height) + " " + in->format_name() + " image");
  Image image(spec.width, spec.height, spec.nchannels, assume ? *assume : color_space_of(spec));
  bool decoded;
  {
    SilencedStderr silence(std::string(in->format_name()) == "png");
    decoded = in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, image.pixels.data());
  }
  if (!decoded) {
    throw InvalidInput(path, "cannot decode pixels (" + one_line(in->geterror()) + ")", "the file is truncated or corrupt");
  }
  in->close();
  for (float v : image.pixels) {
    if (!std::isfinite(v)) {
      throw InvalidInput(path, "image holds NaN or infinite values", "repair the image (e.g. oiiotool --fixnan box3)");
    }
  }
  return image;
}

void ImageWriteOptions::check() const {
  if (jpeg_quality < 1 || jpeg_quality > 100)
    throw InvalidInput("jpeg_quality", "must be in [1, 100] (got " + std::to_string(jpeg_quality) + ")", "e.g. 95");
  png.check();
}

namespace {

// Opens an OpenImageIO output on `file`'s temporary with our conventions: storage type from the options or the
// extension, colour-space tag, compression, tiles and mip levels. Throws naming `path`.
std::unique_ptr<OIIO::ImageOutput> open_output(const std::string& path, const AtomicFile& file, int width, int height,
                                               int channels, ColorSpace space, const ImageWriteOptions& options,
                                               OIIO::ImageSpec& spec) {
  options.check();
  const std::string ext = lower_extension(path);
  PixelType type = PixelType::UInt8;
  if (options.type) {
    type = *options.type;
  } else if (ext == ".exr") {
    type = PixelType::Half;
  } else if (ext == ".tif" || ext == ".tiff") {
    type = PixelType::UInt16;
  }
  auto out = OIIO::ImageOutput::create(file.temp_path());
  if (!out) throw InvalidInput(path, "unsupported image format '" + ext + "'", "use .png, .jpg, .tif or .exr");
  spec = OIIO::ImageSpec(width, height, channels, oiio_type(type));
  spec.attribute("oiio:ColorSpace", space == ColorSpace::sRGB ? "sRGB" : space == ColorSpace::Data ? "Raw" : "Linear");
  if (!options.compression.empty()) {
    spec.attribute("compression", options.compression);
  } else if (ext == ".exr") {
    spec.attribute("compression", "zip");
  }
  if (ext == ".jpg" || ext == ".jpeg") spec.attribute("Compression", "jpeg:" + std::to_string(options.jpeg_quality));
  if (ext == ".png") {  // the settings of encode_png with options.png (core/png.cc)
    if (!options.compression.empty())
      throw InvalidInput(path, "PNG takes no compression '" + options.compression + "'", "set ImageWriteOptions::png");
    spec.attribute("png:compressionLevel", options.png.level);
    spec.attribute("compression", options.png.fast ? "rle" : "default");
    spec.attribute("png:filter", options.png.fast ? PNG_FILTER_SUB : PNG_ALL_FILTERS);
  }
  if (options.tiled || options.mipmap) {
    if (!out->supports("tiles")) throw InvalidInput(path, "format cannot store tiles", "write .exr or .tif");
    spec.tile_width = spec.tile_height = 64;
  }
  if (options.mipmap && !out->supports("mipmap")) {
    throw InvalidInput(path, "format cannot store mip levels", "write .exr or .tif");
  }
  if (options.mipmap) {
    spec.attribute("textureformat", "Plain Texture");
    spec.attribute("openexr:levelmode", 1);  // MIPMAP_LEVELS: OpenEXR must know at open time
  }
  if (!out->open(file.temp_path(), spec, OIIO::ImageOutput::Create)) write_failed(path, out->geterror());
  return out;
}

}  // namespace

void write_image(const std::string& path, const Image& image, const ImageWriteOptions& options) {
  if (image.empty() || image.width <= 0 || image.height <= 0 || image.channels <= 0 ||
      image.pixels.size() != size_t(image.width) * image.height * image.channels) {
    throw InternalError(path + ": write_image called with an inconsistent image");
  }
  AtomicFile file(path);
  OIIO::ImageSpec spec;
  auto out = open_output(path, file, image.width, image.height, image.channels, image.color_space, options, spec);
  Image level = image;
  for (;;) {
    if (!out->write_image(OIIO::TypeDesc::FLOAT, level.pixels.data())) write_failed(path, out->geterror());
    if (!options.mipmap || (level.width == 1 && level.height == 1)) break;
    // Filter colour in linear light; store the level in the image's own encoding.
    Image next = level.color_space == ColorSpace::sRGB ? to_srgb(half_size(to_linear(level))) : half_size(level);
    level = std::move(next);
    OIIO::ImageSpec level_spec = spec;
    level_spec.width = level_spec.full_width = level.width;
    level_spec.height = level_spec.full_height = level.height;
    if (!out->open(file.temp_path(), level_spec, OIIO::ImageOutput::AppendMIPLevel)) {
      write_failed(path, out->geterror());
    }
  }
  if (!out->close()) write_failed(path, out->geterror());
  out.reset();
  file.commit();
}

struct ImageStreamWriter::Impl {
  std::string path;
  AtomicFile file;
  std::unique_ptr<OIIO::ImageOutput> out;
  int width, height, channels, next_row = 0;
  explicit Impl(const std::string& p) : path(p), file(p) {}
};

ImageStreamWriter::ImageStreamWriter(const std::string& path, int width, int height, int channels, ColorSpace space,
                                     const ImageWriteOptions& options) {
  if (width <= 0 || height <= 0 || channels <= 0) throw InternalError(path + ": stream writer with an empty size");
  if (options.tiled || options.mipmap) throw InternalError(path + ": stream writer writes scanline files only");
  impl_ = std::make_unique<Impl>(path);
  impl_->width = width;
  impl_->height = height;
  impl_->channels = channels;
  OIIO::ImageSpec spec;
  impl_->out = open_output(path, impl_->file, width, height, channels, space, options, spec);
}

ImageStreamWriter::~ImageStreamWriter() = default;
ImageStreamWriter::ImageStreamWriter(ImageStreamWriter&&) noexcept = default;

void ImageStreamWriter::write_rows(int y_begin, int y_end, const float* pixels) {
  Impl& s = *impl_;
  if (y_begin != s.next_row || y_end <= y_begin || y_end > s.height) {
    throw InternalError(s.path + ": rows written out of order");
  }
  if (!s.out->write_scanlines(y_begin, y_end, 0, OIIO::TypeDesc::FLOAT, pixels)) write_failed(s.path, s.out->geterror());
  s.next_row = y_end;
}

void ImageStreamWriter::commit() {
  Impl& s = *impl_;
  if (s.next_row != s.height) throw InternalError(s.path + ": committed before every row was written");
  if (!s.out->close()) write_failed(s.path, s.out->geterror());
  s.out.reset();
  s.file.commit();
}

struct ImageStreamReader::Impl {
  std::string path;
  std::unique_ptr<OIIO::ImageInput> in;
  ImageFileInfo info;
};

ImageStreamReader::ImageStreamReader(const std::string& path, std::optional<ColorSpace> assume)
    : impl_(std::make_unique<Impl>()) {
  impl_->path = path;
  impl_->info = probe_image(path);
  if (assume) impl_->info.color_space = *assume;
  impl_->in = open_input(path);
}

ImageStreamReader::~ImageStreamReader() = default;

const ImageFileInfo& ImageStreamReader::info() const { return impl_->info; }

void ImageStreamReader::read_rows(int y_begin, int y_end, float* pixels) {
  const ImageFileInfo& info = impl_->info;
  bool decoded;
  {
    SilencedStderr silence(std::string(impl_->in->format_name()) == "png");
    decoded = impl_->in->read_scanlines(0, 0, y_begin, y_end, 0, 0, info.channels, OIIO::TypeDesc::FLOAT, pixels);
  }
  if (!decoded) {
    throw InvalidInput(impl_->path, "cannot decode rows " + std::to_string(y_begin) + "-" + std::to_string(y_end) + " (" +
                                        one_line(impl_->in->geterror()) + ")",
                       "the file is truncated or corrupt");
  }
  const size_t n = size_t(y_end - y_begin) * size_t(info.width) * size_t(info.channels);
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(pixels[i])) {
      throw InvalidInput(impl_->path, "image holds NaN or infinite values", "repair the image (e.g. oiiotool --fixnan box3)");
    }
  }
}

}  // namespace bareskin
