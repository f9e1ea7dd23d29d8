// `uvtools mean`: the mean of maps in one UV layout, in linear light. Its main use is the reference of `scan register
// --texture-landmarks` / `--texture-refine`: the mean of other scans' registered diffuse maps, where individual
// freckles and pores average out and the features every face has at the same place (brows, eyes, lips) stay.
#pragma once
#include <string>
#include <vector>

#include "core/image.h"
#include "core/progress.h"

namespace bareskin {

struct MapMean {
  Image image;                          // RGB, in the first map's colour space (sRGB, linear or data)
  PixelType stored = PixelType::UInt8;  // how the first map's file stores its values
  double covered_fraction = 0;          // texels that at least one map covers
};

// Texels black in a map (outside its transfer: the three channels summing to at most 1e-4 in linear light) do not
// count towards that texel's mean; texels black in every map stay black. Throws IoError / InvalidInput naming the
// file for an unreadable map, one that is not RGB, or one whose size differs from the first's.
MapMean mean_of_maps(const std::vector<std::string>& paths, const ProgressCallback& progress = {});

// Writes it: .exr linear (float when the first map was float, else half), .png/.tif sRGB at the first map's depth
// (8-bit stays 8-bit, anything finer goes to 16-bit).
void write_map_mean(const std::string& path, const MapMean& mean);

}  // namespace bareskin
