#include "detect/multiview_landmarks.h"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <spdlog/spdlog.h>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/files.h"
#include "core/landmarks.h"
#include "core/scan_folder.h"
#include "detect/scan_landmarks.h"
#include "render/preview.h"
#include "render/shade.h"

namespace bareskin::detect {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}


}  // namespace

LandmarkView detect_view(const FaceApi& net, const Image& photo_srgb, const Camera& camera, int refinements,
                         double min_score) {
  LandmarkView view;
  view.camera = camera;
  view.px.setConstant(std::numeric_limits<double>::quiet_NaN());
  const torch::Tensor photo = photo_tensor(photo_srgb, "view");
  DetectOptions detect;
  detect.min_score = min_score;
  detect.max_faces = 1;
  const auto faces = net.detect(photo, detect);
  if (faces.empty()) return view;
  view.score = faces[0].score;
  Box box = faces[0].box;
  for (int pass = 0; pass <= refinements; ++pass) {
    view.px = net.landmarks(photo, {box})[0];
    box = box_around(view.px);
  }
  return view;
}

void MultiviewOptions::check() const {
  if (views < 1 || views > 100)
    throw InvalidInput("--views", std::to_string(views) + " virtual cameras is outside [1, 100]", "use e.g. 16 (default)");
  if (size < 128 || size > 4096)
    throw InvalidInput("--view-size", "the render size " + std::to_string(size) + " is outside [128, 4096]",
                       "use e.g. 384 (default)");
  check_refinements(refinements);
  if (!(max_yaw_deg >= 0 && max_yaw_deg <= 90) || !(max_pitch_deg >= 0 && max_pitch_deg <= 90))
    throw InvalidInput("the view ring", "its yaw and pitch spans must lie in [0, 90] degrees", "use e.g. 40 and 25");
  triangulate.check();
}

MultiviewScanLandmarks detect_multiview_landmarks(const FaceApi& net, const Mesh& scan, const Image* diffuse,
                                                  const MultiviewOptions& options, bool keep_pictures) {
  options.check();
  if (scan.V.rows() == 0 || scan.F.rows() == 0) throw InvalidInput("", "the scan is empty", "check the mesh file");
  const Eigen::Vector3d centre = (scan.V.colwise().minCoeff() + scan.V.colwise().maxCoeff()).transpose() / 2;
  const std::vector<Camera> cameras =
      landmark_view_ring(options.views, options.size, centre, 1000, options.max_yaw_deg, options.max_pitch_deg);
  ShadeOptions shade;
  shade.texture = diffuse;
  shade.gamma = default_lighting();
  MultiviewScanLandmarks out;
  for (const Camera& camera : cameras) {
    auto t0 = std::chrono::steady_clock::now();
    const Image picture = to_srgb(render_frame(scan, camera, shade).colour);
    out.seconds_render += seconds_since(t0);
    t0 = std::chrono::steady_clock::now();
    out.views.push_back(detect_view(net, picture, camera, options.refinements, options.triangulate.min_score));
    out.seconds_detect += seconds_since(t0);
    if (keep_pictures) out.pictures.push_back(picture);
  }
  const auto t0 = std::chrono::steady_clock::now();
  out.result = triangulate_landmarks(scan, out.views, options.triangulate);
  out.seconds_triangulate = seconds_since(t0);
  return out;
}

LandmarkCalibration calibrate_on_scans(const FaceApi& net, const std::string& scans, int count,
                                       const MultiviewOptions& options) {
  options.check();
  std::vector<std::string> dirs;
  if (!std::filesystem::is_directory(scans)) throw InvalidInput(scans, "is not a folder", "pass a folder of scan folders");
  for (const auto& e : std::filesystem::directory_iterator(scans))
    if (e.is_directory() && std::filesystem::exists(e.path() / "landmarks.json")) dirs.push_back(e.path().string());
  std::sort(dirs.begin(), dirs.end());
  if (count > 0 && int(dirs.size()) > count) dirs.resize(size_t(count));
  if (dirs.size() < 2)
    throw InvalidInput(scans, "holds " + std::to_string(dirs.size()) + " scan folder(s) with landmarks.json",
                       "a calibration needs two or more scans with known 3D landmarks");
  std::vector<MultiviewLandmarks> found;
  std::vector<Landmarks> truth;
  for (const std::string& dir : dirs) {
    const TexturedScan scan = read_textured_scan(dir);
    truth.push_back(read_landmarks(dir + "/landmarks.json"));
    if (truth.back().points.rows() != 68 || truth.back().points.cols() != 3)
      throw InvalidInput(dir + "/landmarks.json", "needs 68 3D points", "give the scan's iBUG-68 landmarks in mm");
    found.push_back(detect_multiview_landmarks(net, scan.mesh, scan.diffuse ? &*scan.diffuse : nullptr, options).result);
    spdlog::info("landmarks calibrate: {}: {} of {} views with a face", dir, found.back().views_detected, options.views);
  }
  LandmarkCalibration c = calibrate_landmarks(found, truth);
  std::vector<double> best;
  for (int i = 17; i < 68; ++i) best.push_back(std::min(c.spread_detected_mm[i], c.spread_shape_mm[i]));
  std::nth_element(best.begin(), best.begin() + 25, best.end());
  spdlog::info("landmarks calibrate: {} scans, leave-one-out median error over 17-67 {:.2f} mm", dirs.size(), best[25]);
  return c;
}

void CalibrationFilesOptions::check() const {
  if (scans.empty() || output.empty()) throw InvalidInput("landmarks calibrate", "needs --scans and -o", "see --help");
  if (count < 0) throw InvalidInput("--count", "must not be negative", "0 uses every scan");
  multiview.check();
}

void write_calibration(const CalibrationFilesOptions& o) {
  o.check();
  check_output_file(o.output);
  check_output_apart(o.output, {o.scans});
  const FaceApi net(o.weights.empty() ? default_face_api_folder() : o.weights);
  write_file_atomic(o.output, landmark_calibration_json(calibrate_on_scans(net, o.scans, o.count, o.multiview)));
  spdlog::info("landmarks calibrate: -> {}", o.output);
}

Image draw_multiview(const MultiviewScanLandmarks& found) {
  if (found.pictures.empty()) throw InvalidInput("--draw", "no pictures were kept", "ask for them before detecting");
  const int n = int(found.pictures.size()), cols = int(std::ceil(std::sqrt(double(n)))), rows = (n + cols - 1) / cols;
  const int w = found.pictures[0].width, h = found.pictures[0].height;
  Image sheet(cols * w, rows * h, 3, ColorSpace::sRGB);
  for (int v = 0; v < n; ++v) {
    Image canvas = found.pictures[size_t(v)];
    const LandmarkView& view = found.views[size_t(v)];
    const int radius = std::max(1, w / 256);
    if (view.px.allFinite()) draw_landmarks(canvas, view.px, {1.f, 0.2f, 0.2f}, radius);
    Eigen::MatrixXd back(68, 2);
    int k = 0;
    for (const auto& p : found.result.points)
      if (p.valid) back.row(k++) = view.camera.project(p.point).head<2>().transpose();
    if (k > 0) draw_landmarks(canvas, back.topRows(k), {0.2f, 1.f, 0.3f}, radius);
    const int ox = (v % cols) * w, oy = (v / cols) * h;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int c = 0; c < 3; ++c) sheet.at(ox + x, oy + y, c) = canvas.at(x, y, std::min(c, canvas.channels - 1));
  }
  return sheet;
}

}  // namespace bareskin::detect
