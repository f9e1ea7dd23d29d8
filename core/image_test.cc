#include <gtest/gtest.h>

#include <cmath>

#include "core/files.h"
#include "core/error.h"
#include "core/image.h"
#include "core/image_io.h"
#include "core/png.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

Image gradient(int w, int h, int c, ColorSpace space) {
  Image img(w, h, c, space);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int k = 0; k < c; ++k) img.at(x, y, k) = float((x + 3 * y + 17 * k) % 97) / 96.f;
    }
  }
  return img;
}

double mean_abs_diff(const Image& a, const Image& b) {
  double d = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) d += std::abs(a.pixels[i] - b.pixels[i]);
  return d / double(a.pixels.size());
}

double max_abs_diff(const Image& a, const Image& b) {
  double d = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) d = std::max(d, double(std::abs(a.pixels[i] - b.pixels[i])));
  return d;
}

TEST(Image, SrgbTransferMatchesTheStandard) {
  // Reference values from IEC 61966-2-1.
  EXPECT_NEAR(srgb_to_linear(0.5f), 0.2140411f, 1e-6);
  EXPECT_NEAR(srgb_to_linear(0.04045f), 0.0031308f, 1e-6);  // the two branches meet
  EXPECT_NEAR(linear_to_srgb(0.18f), 0.4613561f, 1e-6);
  for (float v = 0; v <= 1.f; v += 0.01f) EXPECT_NEAR(linear_to_srgb(srgb_to_linear(v)), v, 1e-6);
  Image rgba = gradient(4, 4, 4, ColorSpace::sRGB);
  Image lin = to_linear(rgba);
  EXPECT_EQ(lin.color_space, ColorSpace::Linear);
  EXPECT_EQ(lin.at(1, 1, 3), rgba.at(1, 1, 3)) << "alpha is not transfer-encoded";
  EXPECT_NEAR(lin.at(1, 1, 0), srgb_to_linear(rgba.at(1, 1, 0)), 1e-7);
  EXPECT_THROW(to_linear(gradient(2, 2, 3, ColorSpace::Data)), InvalidInput);
  // to_linear looks the 8-bit values up and computes the rest: srgb_to_linear's bits for every value either way,
  // and on a large image (split over the pool) the same as value by value.
  Image many(300, 300, 3, ColorSpace::sRGB);
  for (size_t i = 0; i < many.pixels.size(); ++i)
    many.pixels[i] = i % 3 == 0 ? float(i % 256) / 255.0f : float(i % 1013) / 1012.0f + (i % 7 == 0 ? 1e-7f : 0.0f);
  const Image fast = to_linear(many);
  for (size_t i = 0; i < many.pixels.size(); ++i)
    ASSERT_EQ(fast.pixels[i], srgb_to_linear(many.pixels[i])) << many.pixels[i];
}

struct Case {
  const char* name;
  PixelType type;
  bool tiled, mip;
  double tolerance;
};

TEST(Image, RoundTripsEveryFormat) {
  const std::string dir = testing::temp_dir();
  const Case cases[] = {
      {"a.png", PixelType::UInt8, false, false, 0.5 / 255 + 1e-6},
      {"a16.png", PixelType::UInt16, false, false, 0.5 / 65535 + 1e-7},
      {"a.tif", PixelType::UInt8, false, false, 0.5 / 255 + 1e-6},
      {"a16.tif", PixelType::UInt16, false, false, 0.5 / 65535 + 1e-7},
      {"h.exr", PixelType::Half, false, false, 1e-3},
      {"f.exr", PixelType::Float, false, false, 0},
      {"tiled.exr", PixelType::Half, true, false, 1e-3},
      {"mip.exr", PixelType::Float, true, true, 0},
      {"a.jpg", PixelType::UInt8, false, false, -0.05},  // lossy (and chroma-subsampled): bound the mean error
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const std::string path = dir + "/" + c.name;
    const Image img = gradient(37, 23, 3, ColorSpace::Linear);
    ImageWriteOptions opt;
    opt.type = c.type;
    opt.tiled = c.tiled;
    opt.mipmap = c.mip;
    write_image(path, img, opt);
    const ImageFileInfo info = probe_image(path);
    EXPECT_EQ(info.width, 37);
    EXPECT_EQ(info.height, 23);
    EXPECT_EQ(info.type, c.type);
    EXPECT_EQ(info.tiled, c.tiled || c.mip);
    if (c.mip) {
      EXPECT_EQ(info.mip_levels, 6);  // 37x23 -> 18x11 -> 9x5 -> 4x2 -> 2x1 -> 1x1
    }
    const Image back = read_image(path);
    ASSERT_EQ(back.pixels.size(), img.pixels.size());
    if (c.tolerance >= 0) {
      EXPECT_LE(max_abs_diff(img, back), c.tolerance);
    } else {
      EXPECT_LE(mean_abs_diff(img, back), -c.tolerance);
    }
  }
}

TEST(Image, ColourSpaceTagSurvives) {
  const std::string dir = testing::temp_dir();
  write_image(dir + "/s.png", gradient(8, 8, 3, ColorSpace::sRGB));
  EXPECT_EQ(read_image(dir + "/s.png").color_space, ColorSpace::sRGB);
  write_image(dir + "/l.exr", gradient(8, 8, 3, ColorSpace::Linear));
  EXPECT_EQ(read_image(dir + "/l.exr").color_space, ColorSpace::Linear);
  EXPECT_EQ(read_image(dir + "/l.exr", ColorSpace::Data).color_space, ColorSpace::Data);
}

TEST(Image, CorruptFilesAreInvalidInputAndOutputIsAtomic) {
  const std::string dir = testing::temp_dir();
  write_image(dir + "/good.png", gradient(64, 64, 3, ColorSpace::sRGB));
  write_image(dir + "/good.exr", gradient(64, 64, 3, ColorSpace::Linear));
  for (const char* name : {"good.png", "good.exr"}) {
    const std::string bytes = read_file(dir + "/" + name);
    const std::string cut = dir + "/cut_" + name;
    testing::write_text(cut, bytes.substr(0, bytes.size() / 2));
    EXPECT_THROW(read_image(cut), InvalidInput) << name;
  }
  testing::write_text(dir + "/text.png", "not an image");
  EXPECT_THROW(read_image(dir + "/text.png"), InvalidInput);
  EXPECT_THROW(read_image(dir + "/missing.png"), IoError);
  EXPECT_THROW(write_image("/nonexistent_dir/a.png", gradient(4, 4, 3, ColorSpace::sRGB)), IoError);
  const size_t before = testing::count_files(dir);
  EXPECT_THROW(write_image(dir + "/a.xyz", gradient(4, 4, 3, ColorSpace::sRGB)), InvalidInput);
  EXPECT_EQ(testing::count_files(dir), before) << "no partial output";
}

// write_image's PNG and encode_png's share the project's encoding (core/png_encoding.h): the same compressed rows
// (IDAT) from the same pixels, the default and the filter search alike; bad options are InvalidInput, no file left.
TEST(Image, PngFilesAreEncodedAsInMemory) {
  const std::string dir = testing::temp_dir();
  const auto idat = [](const std::string& png) {
    std::string rows;
    for (size_t at = 8; at + 12 <= png.size();) {
      const auto* p = reinterpret_cast<const unsigned char*>(png.data() + at);
      const size_t length = (size_t(p[0]) << 24) | (size_t(p[1]) << 16) | (size_t(p[2]) << 8) | p[3];
      if (png.compare(at + 4, 4, "IDAT") == 0) rows += png.substr(at + 8, length);
      at += 12 + length;
    }
    return rows;
  };
  const Image img = gradient(61, 47, 3, ColorSpace::sRGB);
  for (const bool fast : {true, false}) {
    ImageWriteOptions w;
    w.png.fast = fast;
    write_image(dir + "/p.png", img, w);
    const std::string rows = idat(read_file(dir + "/p.png"));
    EXPECT_FALSE(rows.empty());
    EXPECT_EQ(rows, idat(encode_png(img, 8, w.png))) << "fast " << fast;
  }
  const size_t before = testing::count_files(dir);
  ImageWriteOptions bad;
  bad.png.level = 10;
  EXPECT_THROW(write_image(dir + "/bad.png", img, bad), InvalidInput);
  bad = {};
  bad.jpeg_quality = 0;
  EXPECT_THROW(write_image(dir + "/bad.jpg", img, bad), InvalidInput);
  EXPECT_THROW(encode_png(img, 8, PngEncoding{-1, true}), InvalidInput);
  EXPECT_EQ(testing::count_files(dir), before) << "no partial output";
}

}  // namespace
}  // namespace bareskin
