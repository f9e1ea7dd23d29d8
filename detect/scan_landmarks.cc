#include "detect/scan_landmarks.h"

#include <torch/torch.h>

#include <cmath>

#include "core/error.h"
#include "render/rasterize.h"
#include "render/shade.h"

namespace bareskin::detect {
namespace {

// face-api's detector boxes span about 1.22× the landmarks' extent, starting 0.14 (x) and 0.12 (y) of it before
// their minimum (measured on astronaut.png); refinements feed the landmark network boxes of that shape.
Box box_around(const Eigen::Matrix<double, 68, 2>& p) {
  const Eigen::Vector2d lo = p.colwise().minCoeff(), size = p.colwise().maxCoeff().transpose() - lo;
  return {lo.x() - 0.138 * size.x(), lo.y() - 0.117 * size.y(), 1.219 * size.x(), 1.217 * size.y()};
}

}  // namespace

ScanLandmarks detect_scan_landmarks(const FaceApi& net, const Mesh& scan, const Image* diffuse,
                                    const ScanLandmarkOptions& options) {
  if (scan.V.rows() == 0 || scan.F.rows() == 0) throw InvalidInput("", "the scan is empty", "check the mesh file");
  const Eigen::Vector3d centre = (scan.V.colwise().minCoeff() + scan.V.colwise().maxCoeff()).transpose() / 2;
  const Camera camera = view_camera("front", options.size, centre);
  ShadeOptions shade;
  shade.texture = diffuse;
  shade.gamma = default_lighting();
  const Frame frame = render_frame(scan, camera, shade);
  ScanLandmarks result;
  result.picture = to_srgb(frame.colour);
  const torch::Tensor photo = photo_tensor(result.picture, "front render");

  DetectOptions detect;
  detect.min_score = options.min_score;
  detect.max_faces = 1;
  const auto faces = net.detect(photo, detect);
  Box box;
  if (!faces.empty()) {
    box = faces[0].box;
    result.detector_score = faces[0].score;
  } else {  // the coverage's bounding box
    int x0 = frame.mask.width, y0 = frame.mask.height, x1 = -1, y1 = -1;
    for (int y = 0; y < frame.mask.height; ++y)
      for (int x = 0; x < frame.mask.width; ++x)
        if (frame.mask.at(x, y) > 0.5f) x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    if (x1 < 0) throw InvalidInput("", "the scan does not cover its front render", "check that the mesh faces +z");
    box = {double(x0), double(y0), double(x1 - x0 + 1), double(y1 - y0 + 1)};
  }
  for (int pass = 0; pass <= options.refinements; ++pass) {
    result.px = net.landmarks(photo, {box})[0];
    box = box_around(result.px);
  }

  // Back-projection: the surface point under each landmark; points off the silhouette (jaw contour) snap to the
  // nearest covered pixel.
  const RasterOutput raster = rasterize_mesh(scan, camera);
  result.landmarks.units = "mm";
  result.landmarks.points.resize(68, 3);
  for (int i = 0; i < 68; ++i) {
    const int px = std::clamp(int(std::floor(result.px(i, 0))), 0, raster.width - 1);
    const int py = std::clamp(int(std::floor(result.px(i, 1))), 0, raster.height - 1);
    const int reach = options.size / 16;
    int best = -1;
    double best_d2 = double(reach) * reach + 1;
    for (int dy = -reach; dy <= reach; ++dy)
      for (int dx = -reach; dx <= reach; ++dx) {
        const int x = px + dx, y = py + dy;
        if (x < 0 || y < 0 || x >= raster.width || y >= raster.height) continue;
        const size_t k = size_t(y) * raster.width + x;
        if (raster.triangle[k] >= 0 && dx * dx + dy * dy < best_d2) best = int(k), best_d2 = dx * dx + dy * dy;
      }
    if (best < 0)
      throw InvalidInput("", "landmark " + std::to_string(i) + " lies more than " + std::to_string(reach) +
                                 " px off the scan in its front render",
                         "give the scan a landmarks.json");
    result.off_surface += best_d2 > 0;
    const Eigen::Vector3i f = scan.F.row(raster.triangle[size_t(best)]);
    const double b1 = raster.bary[2 * size_t(best)], b2 = raster.bary[2 * size_t(best) + 1];
    result.landmarks.points.row(i) = (1 - b1 - b2) * scan.V.row(f[0]) + b1 * scan.V.row(f[1]) + b2 * scan.V.row(f[2]);
  }
  return result;
}

}  // namespace bareskin::detect
