#include "uvtools/mean.h"

#include <algorithm>
#include <cstdio>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"

namespace bareskin {

MapMean mean_of_maps(const std::vector<std::string>& paths, const ProgressCallback& progress) {
  if (paths.empty()) throw InvalidInput("", "no maps to average", "give one or more maps in the same UV layout");
  std::vector<double> sum;
  std::vector<int> count;
  Image first;
  MapMean out;
  for (size_t m = 0; m < paths.size(); ++m) {
    Image map = read_image(paths[m]);
    if (map.channels < 3) {
      throw InvalidInput(paths[m], "has " + std::to_string(map.channels) + " channel(s), not RGB", "give colour maps");
    }
    if (m == 0) {
      out.stored = probe_image(paths[m]).type;
      first = Image(map.width, map.height, 3, map.color_space);
      sum.assign(size_t(map.width) * size_t(map.height) * 3, 0.0);
      count.assign(size_t(map.width) * size_t(map.height), 0);
    } else if (map.width != first.width || map.height != first.height) {
      char what[160];
      std::snprintf(what, sizeof what, "is %dx%d, the first map (%s) %dx%d", map.width, map.height, paths[0].c_str(),
                    first.width, first.height);
      throw InvalidInput(paths[m], what, "give maps of one size (uvtools bake resizes them)");
    }
    if (map.color_space == ColorSpace::sRGB) map = to_linear(map);
    for (size_t i = 0; i < count.size(); ++i) {
      const float* p = &map.pixels[i * size_t(map.channels)];
      if (double(p[0]) + p[1] + p[2] <= 1e-4) continue;
      for (int c = 0; c < 3; ++c) sum[3 * i + size_t(c)] += p[c];
      ++count[i];
    }
    report(progress, int64_t(m + 1), int64_t(paths.size()), "maps");
  }
  Image mean(first.width, first.height, 3, first.color_space == ColorSpace::Data ? ColorSpace::Data : ColorSpace::Linear);
  int64_t covered = 0;
  for (size_t i = 0; i < count.size(); ++i) {
    if (count[i] == 0) continue;
    ++covered;
    for (int c = 0; c < 3; ++c) mean.pixels[3 * i + size_t(c)] = float(sum[3 * i + size_t(c)] / count[i]);
  }
  out.image = first.color_space == ColorSpace::sRGB ? to_srgb(mean) : mean;
  out.covered_fraction = double(covered) / double(std::max<size_t>(count.size(), 1));
  return out;
}

void write_map_mean(const std::string& path, const MapMean& mean) {
  const bool exr = lower_extension(path) == ".exr";
  Image image = mean.image;
  if (exr && image.color_space == ColorSpace::sRGB) image = to_linear(image);
  if (!exr && image.color_space == ColorSpace::Linear) image = to_srgb(image);
  ImageWriteOptions w;
  if (!exr) w.type = mean.stored == PixelType::UInt8 ? PixelType::UInt8 : PixelType::UInt16;
  if (exr && mean.stored == PixelType::Float) w.type = PixelType::Float;
  write_image(path, image, w);
}

}  // namespace bareskin
