// An image as interleaved float pixels, rows top to bottom, with the colour space its values are in.
// All maths happens in linear light; sRGB is an encoding for 8/16-bit files (docs/pipeline.md).
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

namespace bareskin {

enum class ColorSpace {
  Linear,  // linear-light colour (EXR diffuse, renders before display)
  sRGB,    // sRGB-encoded colour (8/16-bit diffuse, photos)
  Data,    // not colour: normals, roughness, specular, masks, depth; never transfer-encoded
};
const char* to_string(ColorSpace space);

// How values are stored in a file (the Image itself is always float).
enum class PixelType { UInt8, UInt16, Half, Float };
const char* to_string(PixelType type);

struct Image {
  int width = 0, height = 0, channels = 0;
  ColorSpace color_space = ColorSpace::Linear;
  std::vector<float> pixels;  // width * height * channels, interleaved

  Image() = default;
  Image(int width, int height, int channels, ColorSpace space = ColorSpace::Linear, float fill = 0.f);
  bool empty() const { return pixels.empty(); }
  size_t index(int x, int y, int c = 0) const { return (size_t(y) * width + x) * channels + c; }
  float& at(int x, int y, int c = 0) { return pixels[index(x, y, c)]; }
  float at(int x, int y, int c = 0) const { return pixels[index(x, y, c)]; }
};

// Bilinear lookup at texture coordinates (u, v), origin bottom-left, clamped at the border; the first three channels
// (a grey image repeats its channel).
Eigen::Vector3f sample_bilinear(const Image& image, const Eigen::Vector2d& uv);

// The sRGB transfer functions (IEC 61966-2-1), exact piecewise form.
float srgb_to_linear(float encoded);
float linear_to_srgb(float linear);

// Converts colour channels (all but a 4th alpha channel) between Linear and sRGB; a Data image is rejected with
// InvalidInput because its values are not colour.
Image to_linear(const Image& image);
Image to_srgb(const Image& image);

// Area-correct resize of a square image to size² (box filter when shrinking by an integer factor, bilinear otherwise).
Image resize_square(const Image& image, int size);

}  // namespace bareskin
