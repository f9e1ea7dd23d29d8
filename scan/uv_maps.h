// The four skin maps of a UV atlas, filled texel by texel and streamed to disk a band of rows at a time, so maps of
// any size (16K) need memory for one band only. Used by the synthetic bake (scan/skin_bake.h) and by texture transfer
// (scan/transfer.h). Conventions (docs/file_formats.md): diffuse sRGB in PNG/TIFF and linear in EXR; normal
// tangent-space as (n + 1) / 2, +y up; roughness and specular as they are.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <string>

#include "core/mesh.h"
#include "core/progress.h"

namespace bareskin {

enum class MapFormat { Png16, Tiff16, Exr };
MapFormat parse_map_format(const std::string& name);  // "png", "tif", "exr"; InvalidInput otherwise
const char* map_extension(MapFormat format);          // ".png", ".tif", ".exr"

struct BakeOptions {
  int resolution = 2048;  // maps are resolution x resolution
  int gutter = 4;         // texels outside the charts filled from the nearest chart edge
  MapFormat format = MapFormat::Png16;
  int band_rows = 64;     // rows rasterised and written at a time
  void check() const;
};

// Which of the four maps a bake writes (a scan may bring only some: photogrammetry gives a diffuse map alone).
struct MapSelection {
  bool diffuse = true, normal = true, roughness = true, specular = true;
  bool any() const { return diffuse || normal || roughness || specular; }
};

struct MapTexel {
  Eigen::Vector3f diffuse;  // linear
  Eigen::Vector3f normal;   // tangent space, unit
  float roughness, specular;
};

// For each texel centre of the mesh's UV atlas: the face whose UV triangle holds it, or within `options.gutter` texels
// the nearest face at its closest point; `texel(face, barycentric, x, y)` gives the value at texel (x, y), rows from
// the top (called in parallel).
// Writes dir/{diffuse,normal,roughness,specular}<ext> (those `which` selects; the texel's other fields are ignored)
// atomically; texels outside every chart are 0 (normal: +z).
void write_uv_maps(const Mesh& mesh, const BakeOptions& options, const std::string& dir,
                   const std::function<MapTexel(int face, const Eigen::Vector3f& barycentric, int x, int y)>& texel,
                   const ProgressCallback& progress = {}, const MapSelection& which = {});

}  // namespace bareskin
