#include "core/image.h"

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"

namespace bareskin {

const char* to_string(ColorSpace space) {
  switch (space) {
    case ColorSpace::Linear: return "linear";
    case ColorSpace::sRGB: return "sRGB";
    case ColorSpace::Data: return "data";
  }
  return "?";
}

const char* to_string(PixelType type) {
  switch (type) {
    case PixelType::UInt8: return "uint8";
    case PixelType::UInt16: return "uint16";
    case PixelType::Half: return "half";
    case PixelType::Float: return "float";
  }
  return "?";
}

Image::Image(int w, int h, int c, ColorSpace space, float fill)
    : width(w), height(h), channels(c), color_space(space), pixels(size_t(w) * h * c, fill) {}

float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

float linear_to_srgb(float v) {
  return v <= 0.0031308f ? v * 12.92f : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

namespace {
// srgb_to_linear of the 256 values an 8-bit file decodes to (i / 255): looked up when the input is exactly one of
// them, computed otherwise, so the result is srgb_to_linear's to the bit either way.
float srgb_to_linear_fast(float v) {
  struct Table {
    float in[256], out[256];
    Table() {
      for (int i = 0; i < 256; ++i) in[i] = float(i) / 255.0f, out[i] = srgb_to_linear(in[i]);
    }
  };
  static const Table table;
  const float scaled = v * 255.0f;
  if (scaled >= 0 && scaled <= 255) {
    const int i = int(scaled + 0.5f);
    if (table.in[i] == v) return table.out[i];
  }
  return srgb_to_linear(v);
}

Image convert(const Image& image, ColorSpace target, float (*transfer)(float)) {
  if (image.color_space == ColorSpace::Data) {
    throw InvalidInput("", "cannot convert a data image (normals, roughness, masks) between colour spaces",
                       "only colour images have an sRGB encoding");
  }
  Image out = image;
  if (image.color_space == target) return out;
  out.color_space = target;
  const int colour_channels = image.channels == 4 ? 3 : image.channels;
  const size_t C = size_t(image.channels);
  parallel_for(0, int64_t(out.pixels.size() / C), [&](int64_t b, int64_t e) {  // per value: the same on any pool
    for (size_t p = size_t(b) * C; p < size_t(e) * C; p += C)
      for (int c = 0; c < colour_channels; ++c) out.pixels[p + size_t(c)] = transfer(out.pixels[p + size_t(c)]);
  }, 1 << 16);
  return out;
}
}  // namespace

Image to_linear(const Image& image) { return convert(image, ColorSpace::Linear, srgb_to_linear_fast); }
Image to_srgb(const Image& image) { return convert(image, ColorSpace::sRGB, linear_to_srgb); }

Eigen::Vector3f sample_bilinear(const Image& img, const Eigen::Vector2d& uv) {
  const double x = std::clamp(uv.x() * img.width - 0.5, 0.0, img.width - 1.0);
  const double y = std::clamp((1 - uv.y()) * img.height - 0.5, 0.0, img.height - 1.0);
  const int x0 = int(x), y0 = int(y), x1 = std::min(x0 + 1, img.width - 1), y1 = std::min(y0 + 1, img.height - 1);
  const float fx = float(x - x0), fy = float(y - y0);
  Eigen::Vector3f c;
  for (int k = 0; k < 3; ++k) {
    const int ch = std::min(k, img.channels - 1);
    c[k] = (1 - fy) * ((1 - fx) * img.at(x0, y0, ch) + fx * img.at(x1, y0, ch)) +
           fy * ((1 - fx) * img.at(x0, y1, ch) + fx * img.at(x1, y1, ch));
  }
  return c;
}

Image resize_square(const Image& image, int size) {
  if (image.width == size && image.height == size) return image;
  Image out(size, size, image.channels, image.color_space);
  const int C = image.channels;
  if (image.width == image.height && image.width > size && image.width % size == 0) {
    const int f = image.width / size;
    parallel_for(0, size, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y)
        for (int x = 0; x < size; ++x)
          for (int c = 0; c < C; ++c) {
            double s = 0;
            for (int dy = 0; dy < f; ++dy)
              for (int dx = 0; dx < f; ++dx) s += image.at(x * f + dx, int(y) * f + dy, c);
            out.at(x, int(y), c) = float(s / (f * f));
          }
    });
    return out;
  }
  parallel_for(0, size, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y)
      for (int x = 0; x < size; ++x) {
        const double sx = std::clamp((x + 0.5) * image.width / size - 0.5, 0.0, image.width - 1.0);
        const double sy = std::clamp((y + 0.5) * image.height / size - 0.5, 0.0, image.height - 1.0);
        const int x0 = int(sx), y0 = int(sy), x1 = std::min(x0 + 1, image.width - 1), y1 = std::min(y0 + 1, image.height - 1);
        const double fx = sx - x0, fy = sy - y0;
        for (int c = 0; c < C; ++c)
          out.at(x, int(y), c) = float((1 - fy) * ((1 - fx) * image.at(x0, y0, c) + fx * image.at(x1, y0, c)) +
                                       fy * ((1 - fx) * image.at(x0, y1, c) + fx * image.at(x1, y1, c)));
      }
  });
  return out;
}

}  // namespace bareskin
