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
#include "template/surface.h"

namespace bareskin {

// The one per-texel lookup of a transfer (scan/transfer.cc's maps and texture_refine's diffuse): the point of the
// registered surface (rows of V, triangle `face` of F at barycentrics b), its closest scan point and the scan's atlas
// UV there. `ok` is false when the locator's face and weights do not give its point back (they index scan.F and FUV).
struct ScanAtlasPoint {
  bool ok = false;
  SurfacePoint on_scan;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();
};
ScanAtlasPoint scan_atlas_point(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int face, const Eigen::Vector3d& b,
                                const Mesh& scan, const SurfaceLocator& scan_locator);

// A scan's maps; an empty image is a map the scan does not have (photogrammetry gives a diffuse map alone).
struct ScanMaps {
  Image diffuse;                       // linear
  Image normal, roughness, specular;   // data; normal as stored, (n + 1) / 2
  MapSelection present() const;
  std::vector<std::string> names() const;  // the present maps' names, in the order above
};

// Reads whichever of dir/{diffuse,normal,roughness,specular}.{png,tif,tiff,exr} exist (none is fine).
ScanMaps read_scan_maps(const std::string& dir);

struct TransferResult {
  // Per texel of the output (row-major, top row first): 0 no chart, 1 transferred, 2 transferred from scan faces that
  // touch a seam of the scan's atlas (bilinear lookups there may straddle charts).
  std::vector<uint8_t> texel_class;
};

// `registered`: template topology with its UVs, vertices on the scan (mm). `scan`: with UVs. Writes the maps the scan
// has to `out_dir` at options.resolution (at least one must be present).
TransferResult transfer_maps(const Mesh& registered, const Mesh& scan, const ScanMaps& maps, const BakeOptions& options,
                             const std::string& out_dir, const ProgressCallback& progress = {});

// Diffuse PSNR (dB, on sRGB-encoded values in [0,1]) and median normal angle (degrees) between transferred maps and
// truth maps of the same size, over texels of `texel_class` == 1 (away from seams); each only where that map was
// transferred (has_diffuse, has_normal).
struct TransferErrors {
  bool has_diffuse = false, has_normal = false;
  double diffuse_psnr_db = 0, normal_median_deg = 0, normal_p95_deg = 0;
  int64_t texels = 0;
};
TransferErrors compare_maps(const std::string& transferred_dir, const std::string& truth_dir,
                            const std::vector<uint8_t>& texel_class);

}  // namespace bareskin
