// `uvtools bake`: a set of UV maps (diffuse, normal, roughness, specular; 16K and below) resized to smaller sizes in
// one streamed pass, seam-aware and per map type:
// - the input is read a band of rows at a time (ImageStreamReader), so memory does not grow with the input size;
// - each output texel averages the input texels under it (box filter, an integer factor) that lie inside a UV island
//   of the layout mesh, so texels outside the islands never bleed in; output texels with no island texel under them
//   are then filled from their neighbours for `gutter` texels (the padding later filtering needs);
// - diffuse is filtered in linear light (sRGB files are decoded first), normals as vectors and renormalised,
//   roughness and specular as they are; `toksvig` lets the roughness absorb the normal variance the averaging lost.
#pragma once
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/image.h"

#include "core/mesh.h"
#include "core/progress.h"

namespace bareskin {

struct MapResizeOptions {
  std::vector<int> sizes = {4096, 1024};  // each must divide the input size
  std::string format = "exr";             // exr (half, zip, tiled), png or tif (16-bit; diffuse sRGB-encoded)
  bool mipmap = false;                    // EXR/TIFF: write the mip chain too
  bool toksvig = false;                   // roughness += the variance of the averaged normals
  int gutter = 8;                         // output texels filled beyond the islands
  void check() const;                     // InvalidInput when out of range
};

struct MapResizeReport {
  int input_size = 0;
  bool layout = false;                // false: no layout given, every texel counted (no seam handling)
  std::vector<std::string> maps;      // the map names found, in processing order
  double island_fraction = 0;         // of input texels inside a UV island
  int flipped_triangles = 0;          // UV triangles wound against the majority
  int64_t overlapping_texels = 0;     // input texel centres strictly inside two or more UV triangles
};

// The layout's UV islands rasterised at one map size: per input row, the spans of texels a UV triangle covers. It is
// the layout half of a bake and the same for every map set of that size, so make-dataset builds it once per run.
class UvIslands {
 public:
  UvIslands(const Mesh& layout, int size);  // InvalidInput when the layout has no UVs
  int size() const { return size_; }
  // The island mask of rows [y0, y0 + rows) into mask[rows * size] (1 inside).
  void mask_rows(int y0, int rows, std::vector<uint8_t>& mask) const;
  double fraction = 0;             // of texels inside an island
  int flipped_triangles = 0;       // UV triangles wound against the majority
  int64_t overlapping_texels = 0;  // texel centres strictly inside two or more UV triangles

 private:
  int size_;
  std::vector<int64_t> row_start_;                 // spans_[row_start_[y] .. row_start_[y + 1]) are row y's
  std::vector<std::pair<int32_t, int32_t>> spans_;  // [first, last] texel columns
};

// A baked map handed over in memory: map name (diffuse, normal, roughness, specular), output size, and the image
// (diffuse linear RGB; normals encoded (n + 1) / 2; roughness and specular as read).
using BakedMapSink = std::function<void(const std::string& map, int size, Image image)>;

// The bake of resize_maps without the files: every map and size goes to `sink`, map by map (diffuse, normal, roughness,
// specular: those present), largest size first.
// `islands`: the layout raster at the maps' size (InvalidInput when its size differs), or nullptr for no seam handling.
MapResizeReport bake_maps(const std::string& in_dir, const UvIslands* islands, const MapResizeOptions& options,
                          const BakedMapSink& sink, const ProgressCallback& progress = {});

// The size of the map set in `in_dir` (every map square and of one size), or InvalidInput as resize_maps reports it.
int map_set_size(const std::string& in_dir);

// Reads in_dir/{diffuse,normal,roughness,specular}.{exr,tif,tiff,png} (those present; all square and the same size)
// and writes out_dir/<size>/<map>.<format> for every size, atomically (a failure leaves no out_dir). `layout`: a mesh
// whose UVs define the islands (the template); nullptr: no seam handling, a plain area-correct (box) resize per map
// type over every texel. InvalidInput naming the file for mixed sizes, non-square maps, sizes that do not divide the
// input, a zero normal inside an island, truncated or NaN pixels.
MapResizeReport resize_maps(const std::string& in_dir, const Mesh* layout, const MapResizeOptions& options,
                            const std::string& out_dir, const ProgressCallback& progress = {});

// `bareskin uvtools bake` on files: resize_maps of `input` (with the layout mesh file `layout`, or none) into `output`,
// then output/bake.json (input, sizes, maps, layout, island fraction, flipped and overlapping UVs, seconds) and the
// log lines. InvalidInput when the output would replace an input; IoError when `input` is not a folder.
struct BakeFilesOptions {
  std::string input, output;  // the maps' folder; <size>/<map>.<format> and bake.json go to `output`
  std::string layout;         // "" or a mesh whose UV islands the maps follow (seam-aware)
  MapResizeOptions resize;
  void check() const;         // resize.check()
};
MapResizeReport bake_files(const BakeFilesOptions& options, const ProgressCallback& progress = {});

}  // namespace bareskin
