// Landmarks found in the scan's texture (`scan register --texture-landmarks N`, docs/pipeline.md). A detector's
// landmarks are 1-3 mm off on a new face, and the registration follows them along the surface. The brows, eyes and
// lips are drawn in the skin, where every face has them at the same place of the template UV; a registration from
// rough landmarks carries the scan's diffuse into that UV a few texels off, and the flow between it and a reference
// (e.g. the mean of other scans' transfers) says how far. Per landmark of those features, the template vertex's UV
// moved by the flow is where the scan's texture puts it; the registration's surface there is the landmark.
// Luminance finds the brows (17-26) and the eyes (36-47), redness the outer lip line (48-59), whose luminance hardly
// differs from the skin's on darker faces. The nose (27-35), the inner lip line (60-67, where the lips meet) and the
// jaw line (0-16) are not marked in the skin: not found here.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "core/image.h"
#include "core/landmarks.h"
#include "core/mesh.h"
#include "scan/texture_refine.h"
#include "template/surface.h"
#include "template/template_face.h"

namespace bareskin {

struct TextureLandmarks {
  Landmarks landmarks;        // 68 points: the found ones moved, the others where the registration has them
  std::vector<int> ids;       // the landmarks found (ascending)
  double median_move_mm = 0;  // how far the found ones moved from the registration's landmarks
};

// V: the current registration (template topology, on the scan). The flow runs at options.landmark_resolution with
// options.landmark_* sizes (given at 512 texels, scaled to it); a landmark whose flow confidence is below
// options.min_confidence or which moves more than options.max_move_mm is not found.
TextureLandmarks texture_landmarks(const TemplateFace& face, const Eigen::MatrixX3d& V, const Mesh& scan,
                                   const SurfaceLocator& scan_locator, const Image& scan_diffuse,
                                   const Image& reference, const TextureRefineOptions& options);

}  // namespace bareskin
