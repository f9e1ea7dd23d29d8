// unwarp against the renderer: a textured template rendered from the front (albedo pass) and unwarped back into UV
// reproduces the texture where it is seen; a profile view sees less of the face and nothing facing away.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <iostream>

#include "core/error.h"
#include "core/image_io.h"
#include "render/rasterize.h"
#include "render/shade.h"
#include "scan/test_template.h"
#include "uvtools/mean.h"
#include "uvtools/unwarp.h"

namespace bareskin {
namespace {

Image pattern(int size) {
  Image t(size, size, 3, ColorSpace::Linear);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double u = (x + 0.5) / size, v = (y + 0.5) / size;
      t.at(x, y, 0) = float(0.5 + 0.3 * std::sin(12 * u) * std::cos(9 * v));
      t.at(x, y, 1) = float(0.4 + 0.25 * std::cos(15 * v + 2 * u));
      t.at(x, y, 2) = float(0.3 + 0.2 * std::sin(10 * (u + v)));
    }
  return t;
}

TEST(Unwarp, RoundTripReproducesTheSeenTexels) {
  const Mesh& mesh = testing::test_template().mesh;
  const Image texture = pattern(256);
  const Eigen::Vector3d centre = 0.5 * (mesh.V.colwise().minCoeff() + mesh.V.colwise().maxCoeff()).transpose();
  ShadeOptions shade;
  shade.texture = &texture;
  const Camera front = view_camera("front", 1024, centre);
  const Frame frame = render_frame(mesh, front, shade);
  UnwarpOptions options;
  options.size = 256;
  const UnwarpResult r = unwarp(frame.albedo, mesh, front, options);
  ASSERT_GT(r.in_layout, 10000);
  EXPECT_GT(double(r.seen) / double(r.in_layout), 0.6);
  double se = 0;
  int64_t n = 0;
  for (size_t i = 0; i < r.confidence.pixels.size(); ++i) {
    if (r.confidence.pixels[i] < 0.5) continue;
    for (int c = 0; c < 3; ++c) se += std::pow(double(r.colour.pixels[3 * i + size_t(c)]) - texture.pixels[3 * i + size_t(c)], 2);
    n += 3;
  }
  ASSERT_GT(n, 30000);
  const double psnr = 10 * std::log10(1 / (se / double(n)));
  EXPECT_GT(psnr, 35) << "round trip at 256 through a 1024 render";
  std::cout << "round trip: PSNR " << psnr << " dB over " << n / 3 << " texels (confidence >= 0.5), seen "
            << r.seen << " of " << r.in_layout << "\n";

  const UnwarpResult left = unwarp(render_frame(mesh, view_camera("left", 1024, centre), shade).albedo, mesh,
                                   view_camera("left", 1024, centre), options);
  EXPECT_LT(left.seen, r.seen);
  // Seen from the face's left (+x), no texel on the far right side of the face (x well below the centre) is seen.
  const RasterOutput uv = rasterize_uv(mesh, 256);
  for (size_t i = 0; i < left.confidence.pixels.size(); ++i) {
    if (left.confidence.pixels[i] <= 0 || uv.triangle[i] < 0) continue;
    const Eigen::Vector3d p = mesh.V.row(mesh.F(uv.triangle[i], 0)).transpose();
    EXPECT_GT(p.x(), centre.x() - 45) << "texel " << i;
  }
}

TEST(Unwarp, InsideMaskLeavesTexelsTouchingItsZerosUnseen) {
  const Mesh& mesh = testing::test_template().mesh;
  const Eigen::Vector3d centre = 0.5 * (mesh.V.colwise().minCoeff() + mesh.V.colwise().maxCoeff()).transpose();
  const Camera front = view_camera("front", 256, centre);
  const Image image = render_frame(mesh, front, {}).albedo;
  Image inside(256, 256, 1, ColorSpace::Data);
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) inside.pixels[size_t(y) * 256 + size_t(x)] = x < 128 ? 1.f : 0.f;  // image's left half
  UnwarpOptions options;
  options.size = 128;
  const UnwarpResult all = unwarp(image, mesh, front, options);
  options.inside = &inside;
  const UnwarpResult half = unwarp(image, mesh, front, options);
  // Every texel seen with the mask was seen without it, with the same colour; those that project right of x = 127
  // (their bilinear footprint touches the zeros) are not seen; about half of the face remains.
  const RasterOutput uv = rasterize_uv(mesh, 128);
  int64_t kept = 0, dropped_right = 0;
  for (size_t i = 0; i < half.confidence.pixels.size(); ++i) {
    if (all.confidence.pixels[i] <= 0) {
      EXPECT_EQ(half.confidence.pixels[i], 0.f);
      continue;
    }
    const int32_t f = uv.triangle[i];
    const double w[3] = {1.0 - uv.bary[2 * i] - uv.bary[2 * i + 1], uv.bary[2 * i], uv.bary[2 * i + 1]};
    Eigen::Vector3d P = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) P += w[k] * mesh.V.row(mesh.F(f, k)).transpose();
    const double x = front.project(P).x();
    if (half.confidence.pixels[i] > 0) {
      ++kept;
      EXPECT_LT(x, 128.0);
      EXPECT_EQ(half.colour.pixels[3 * i], all.colour.pixels[3 * i]);
    } else if (x >= 128.0) {
      ++dropped_right;
    } else {
      EXPECT_GT(x, 126.5) << "a texel left of the edge was dropped";
    }
  }
  EXPECT_EQ(half.seen, kept);
  EXPECT_GT(kept, all.seen / 3);
  EXPECT_GT(dropped_right, all.seen / 3);
  // The caller's UV raster (one for many unwarps of a layout) gives the same result; one of another size is refused.
  options.uv_raster = &uv;
  const UnwarpResult shared = unwarp(image, mesh, front, options);
  EXPECT_EQ(shared.colour.pixels, half.colour.pixels);
  EXPECT_EQ(shared.confidence.pixels, half.confidence.pixels);
  const RasterOutput other = rasterize_uv(mesh, 64);
  options.uv_raster = &other;
  EXPECT_ANY_THROW(unwarp(image, mesh, front, options));
}

TEST(Unwarp, RefusesAnImageOfAnotherSize) {
  const Mesh& mesh = testing::test_template().mesh;
  EXPECT_THROW(unwarp(Image(100, 100, 3), mesh, view_camera("front", 224, Eigen::Vector3d::Zero())), InvalidInput);
}

// The mean in linear light of 8-bit sRGB maps, black texels left out, against the same sums done here by hand.
TEST(MapMean, AveragesCoveredTexelsInLinearLight) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("bareskin_uvtools_mean_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const float levels[3][4] = {{0.2f, 0.0f, 0.9f, 0.0f}, {0.6f, 0.5f, 0.1f, 0.0f}, {0.4f, 0.7f, 0.3f, 0.0f}};
  std::vector<std::string> paths;
  for (int m = 0; m < 3; ++m) {
    Image map(2, 2, 3, ColorSpace::sRGB);
    for (int i = 0; i < 4; ++i)
      for (int c = 0; c < 3; ++c) map.pixels[size_t(3 * i + c)] = levels[m][i] * (1 - 0.2f * float(c));
    paths.push_back((dir / ("map" + std::to_string(m) + ".png")).string());
    write_image(paths.back(), map);
  }
  const MapMean mean = mean_of_maps(paths);
  ASSERT_EQ(mean.image.color_space, ColorSpace::sRGB);
  EXPECT_DOUBLE_EQ(mean.covered_fraction, 0.75);  // texel 3 is black in every map
  for (int i = 0; i < 4; ++i)
    for (int c = 0; c < 3; ++c) {
      double sum = 0;
      int n = 0;
      for (int m = 0; m < 3; ++m) {
        const float encoded = std::round(levels[m][i] * (1 - 0.2f * float(c)) * 255) / 255;  // what the PNG holds
        if (encoded > 0) sum += srgb_to_linear(encoded), ++n;
      }
      const double want = n ? linear_to_srgb(float(sum / n)) : 0.0;
      EXPECT_NEAR(mean.image.pixels[size_t(3 * i + c)], want, 1e-5) << "texel " << i << " channel " << c;
    }
  // A map of another size is refused, naming it.
  const std::string other = (dir / "other.png").string();
  write_image(other, Image(4, 4, 3, ColorSpace::sRGB, 0.5f));
  try {
    mean_of_maps({paths[0], other});
    ADD_FAILURE() << "a map of another size was averaged";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("other.png"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace bareskin
