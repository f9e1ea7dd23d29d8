// Texture transfer (`scan register --maps-res`): a scan's four maps baked into the template UV through a registration.
// Each template-UV texel's point on the registered mesh is projected onto the scan (closest point), its atlas UV
// looked up and the maps sampled bilinearly; normals are taken out of the scan's tangent frame into world space and
// re-expressed in the template's. Written with write_uv_maps (gutters filled, streamed).
#pragma once
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "scan/uv_maps.h"

namespace bareskin {

struct ScanMaps {
  Image diffuse;                       // linear
  Image normal, roughness, specular;   // data; normal as stored, (n + 1) / 2
};

// Reads dir/{diffuse,normal,roughness,specular}.{png,tif,exr} (the first extension found). InvalidInput naming the
// missing map otherwise.
ScanMaps read_scan_maps(const std::string& dir);

struct TransferResult {
  // Per texel of the output (row-major, top row first): 0 no chart, 1 transferred, 2 transferred from scan faces that
  // touch a seam of the scan's atlas (bilinear lookups there may straddle charts).
  std::vector<uint8_t> texel_class;
};

// `registered`: template topology with its UVs, vertices on the scan (mm). `scan`: with UVs. Writes the four maps to
// `out_dir` at options.resolution.
TransferResult transfer_maps(const Mesh& registered, const Mesh& scan, const ScanMaps& maps, const BakeOptions& options,
                             const std::string& out_dir, const ProgressCallback& progress = {});

// Diffuse PSNR (dB, on sRGB-encoded values in [0,1]) and median normal angle (degrees) between transferred maps and
// truth maps of the same size, over texels of `texel_class` == 1 (away from seams).
struct TransferErrors {
  double diffuse_psnr_db = 0, normal_median_deg = 0, normal_p95_deg = 0;
  int64_t texels = 0;
};
TransferErrors compare_maps(const std::string& transferred_dir, const std::string& truth_dir,
                            const std::vector<uint8_t>& texel_class);

}  // namespace bareskin
