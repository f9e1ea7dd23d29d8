// Landmarks found in the scan's texture and shape (`scan register --texture-landmarks N`, docs/pipeline.md). A detector's
// landmarks are 1-3 mm off on a new face, and the registration follows them along the surface. The brows, eyes and
// lips are drawn in the skin, where every face has them at the same place of the template UV; a registration from
// rough landmarks carries the scan's diffuse into that UV a few texels off, and the flow between it and a reference
// (e.g. the mean of other scans' transfers) says how far. Per landmark of those features, the template vertex's UV
// moved by the flow is where the scan's texture puts it; the registration's surface there is the landmark.
// Luminance finds the brows (17-26) and the eyes (36-47), redness the outer lip line (48-59), whose luminance hardly
// differs from the skin's on darker faces. The nose (27-35) is not marked in the skin but in the shape: the same flow
// between the registration's mean curvature (after a little smoothing) and the template's own finds it. The inner lip
// line (60-67, on the mouth's opening) and the jaw line (0-16, on the face's outline) are neither: not found here.
// The same curvature flow also places shape points: template vertices spread over the whole face, so that the lower
// face and the cheeks, which no landmark marks, follow the scan's shape (the chin, the folds around the mouth).
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
  // Shape points: template vertices (options.shape_points spread over the face, off the border) and where the
  // curvature flow puts them on the registration's surface; those whose flow is unsure are left out.
  std::vector<int> shape_vertex;
  std::vector<Eigen::Vector3d> shape_point;
};

// Finds them round after round for one template and reference: what does not depend on the registration (the
// template's UV raster at options.landmark_resolution, the reference's structure images, the template's curvature) is
// made once. The flows use options.landmark_* sizes (given at 512 texels, scaled to the resolution); a landmark whose
// flow confidence is below options.min_confidence or which moves more than options.max_move_mm is not found.
class TextureLandmarkFinder {
 public:
  TextureLandmarkFinder(const TemplateFace& face, const Image& reference, const TextureRefineOptions& options);
  // V: the current registration (template topology, on the scan).
  TextureLandmarks find(const Eigen::MatrixX3d& V, const Mesh& scan, const SurfaceLocator& scan_locator,
                        const Image& scan_diffuse) const;

  // The one-ring neighbours of each vertex of the template and whether it lies on the border (for the curvature).
  struct Rings {
    std::vector<std::vector<int>> neighbours;
    std::vector<uint8_t> border;
  };

 private:
  const TemplateFace& face_;
  TextureRefineOptions o_;  // the flows' options: sizes scaled to the landmark resolution
  double sigma_ = 0;        // the structure images' sigma (texels)
  RasterOutput raster_;
  std::vector<uint8_t> layout_;  // texels the template's UV layout covers
  std::vector<int> uv_rows_;
  Rings rings_;
  std::vector<int> shape_vertices_;  // the shape points' candidates
  Plane luminance_, redness_, curvature_;  // the reference's (the first two) and the template's structure
};

}  // namespace bareskin
