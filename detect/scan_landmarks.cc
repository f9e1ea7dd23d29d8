#include "detect/scan_landmarks.h"

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <cmath>
#include <memory>

#include "core/error.h"
#include "core/ibug68.h"
#include "render/rasterize.h"
#include "render/shade.h"

namespace bareskin::detect {

// Landmark passes on the box the previous points imply: each costs a landmark net, more than a few change nothing.
void check_refinements(int refinements) {
  if (refinements < 0 || refinements > 10)
    throw InvalidInput("--refinements", std::to_string(refinements) + " is outside [0, 10]", "use e.g. 2 or 3");
}

void ScanLandmarkOptions::check() const {
  if (size < 128 || size > 4096)
    throw InvalidInput("--size", "the render size " + std::to_string(size) + " is outside [128, 4096]",
                       "use e.g. 512 (default)");
  check_refinements(refinements);
  if (!(min_score >= 0 && min_score <= 1))
    throw InvalidInput("the scan detector's threshold", std::to_string(min_score) + " is not a score in [0, 1]",
                       "use e.g. 0.1 (default)");
}

void ImageLandmarkOptions::check() const {
  DetectOptions detect;
  detect.input_size = input_size;
  detect.check();
  check_refinements(refinements);
}

ScanLandmarks detect_scan_landmarks(const FaceApi& net, const Mesh& scan, const Image* diffuse,
                                    const ScanLandmarkOptions& options) {
  options.check();
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

Box box_around(const Eigen::Matrix<double, 68, 2>& p) {
  const Eigen::Vector2d lo = p.colwise().minCoeff(), size = p.colwise().maxCoeff().transpose() - lo;
  return {lo.x() - 0.138 * size.x(), lo.y() - 0.117 * size.y(), 1.219 * size.x(), 1.217 * size.y()};
}

std::optional<Eigen::Matrix<double, 68, 2>> find_image_landmarks(const FaceApi& net, const Image& image,
                                                                 const ImageLandmarkOptions& options) {
  options.check();
  const torch::Tensor photo = photo_tensor(image, "image");
  DetectOptions detection;
  detection.input_size = options.input_size;
  detection.max_faces = 1;
  detection.min_score = 0.3;
  const auto faces = net.detect(photo, detection);
  if (faces.empty() && !options.coverage_fallback) return std::nullopt;
  Box box = faces.empty() ? Box{} : faces[0].box, coverage;
  if (options.coverage_fallback) {
    int x0 = image.width, y0 = image.height, x1 = -1, y1 = -1;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x)
        if (image.at(x, y, 0) + image.at(x, y, 1) + image.at(x, y, 2) > 0)
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    if (x1 < 0) return std::nullopt;
    coverage = {double(x0), double(y0), double(x1 - x0 + 1), double(y1 - y0 + 1)};
    // A detection that hardly overlaps the face's pixels found something else: the coverage box instead.
    const double ix = std::max(0.0, std::min(box.x + box.width, coverage.x + coverage.width) - std::max(box.x, coverage.x));
    const double iy = std::max(0.0, std::min(box.y + box.height, coverage.y + coverage.height) - std::max(box.y, coverage.y));
    const double inter = ix * iy, uni = box.width * box.height + coverage.width * coverage.height - inter;
    if (faces.empty() || inter < 0.3 * uni) box = coverage;
  }
  auto refine = [&](const Box& start) {
    Eigen::Matrix<double, 68, 2> p = net.landmarks(photo, {start})[0];
    for (int pass = 0; pass < options.refinements; ++pass) p = net.landmarks(photo, {box_around(p)})[0];
    return p;
  };
  Eigen::Matrix<double, 68, 2> points = refine(box);
  // Points that collapsed into a small part of the face (the refinements shrank onto a feature): again from the face's
  // pixels.
  if (options.coverage_fallback && box.width != coverage.width &&
      points.col(0).maxCoeff() - points.col(0).minCoeff() < 0.4 * coverage.width)
    points = refine(coverage);
  if (!options.flip) return points;
  // Test-time mirroring: the landmarks of the mirrored image on the mirrored box, mirrored back and relabelled
  // (left and right points swap), averaged with the direct ones.
  const Box b = box_around(points);
  const double W = image.width;
  const Eigen::Matrix<double, 68, 2> mirrored = net.landmarks(photo.flip({1}).contiguous(), {{W - b.x - b.width, b.y, b.width, b.height}})[0];
  Eigen::Matrix<double, 68, 2> back;
  for (int k = 0; k < 68; ++k) back.row(k) = Eigen::RowVector2d(W - mirrored(kIbug68Mirror[k], 0), mirrored(kIbug68Mirror[k], 1));
  return Eigen::Matrix<double, 68, 2>((points + back) / 2);
}

ImageLandmarkFinders face_api_finders(const ImageLandmarkOptions& options) {
  options.check();
  at::set_num_threads(1);
  auto net = std::make_shared<const FaceApi>(default_face_api_folder());
  auto finder = [net, options](bool coverage_fallback) {
    ImageLandmarkOptions o = options;
    o.coverage_fallback = coverage_fallback;
    return [net, o](const Image& image) { return find_image_landmarks(*net, image, o); };
  };
  return {finder(true), finder(false)};
}

}  // namespace bareskin::detect
