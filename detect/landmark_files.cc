#include "detect/landmark_files.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/scan_folder.h"
#include "render/preview.h"
#include "scan/capture.h"
#include "scan/multiview.h"

namespace bareskin::detect {

void PhotoLandmarksOptions::check() const {
  if (photo.empty()) throw InvalidInput("landmarks detect", "names no photo", "give the photo to search");
  for (const std::string& out : {output, draw}) {
    if (!out.empty() && out == photo) throw InvalidInput(out, "would overwrite the photo", "pick another name");
  }
  if (lower_extension(output) != ".json")
    throw InvalidInput(output, "landmarks are written as JSON", "name the output *.json");
  detect.check();
}

void detect_photo_landmarks(const PhotoLandmarksOptions& opt) {
  opt.check();
  FaceApi net(opt.weights.empty() ? default_face_api_folder() : opt.weights);
  net.to(opt.device);
  const Image image = read_image(opt.photo);
  const torch::Tensor photo = photo_tensor(image, opt.photo);
  const auto start = std::chrono::steady_clock::now();
  const auto faces = net.detect(photo, opt.detect);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (faces.empty())
    throw InvalidInput(opt.photo, "no face found with score above " + std::to_string(opt.detect.min_score),
                       "try a lower --min-score or a larger --input-size, or crop the photo around the face");

  auto points_json = [](const Eigen::Matrix<double, 68, 2>& p) {
    auto a = nlohmann::json::array();
    for (int i = 0; i < 68; ++i) a.push_back({p(i, 0), p(i, 1)});
    return a;
  };
  nlohmann::json doc = {{"scheme", "ibug68"}, {"units", "px"}, {"image", opt.photo},
                        {"width", image.width},  {"height", image.height}};
  doc["points"] = points_json(faces[0].points);
  doc["score"] = faces[0].score;
  doc["faces"] = nlohmann::json::array();
  for (const auto& f : faces)
    doc["faces"].push_back({{"score", f.score},
                            {"box", {f.box.x, f.box.y, f.box.width, f.box.height}},
                            {"points", points_json(f.points)}});
  doc["detector"] = {{"model", "face-api 1.7.15 tiny_face_detector + face_landmark_68"},
                     {"input_size", opt.detect.input_size},
                     {"min_score", opt.detect.min_score},
                     {"device", opt.device_name}};

  if (!opt.draw.empty()) {
    Image canvas(image.width, image.height, 3, ColorSpace::sRGB);
    const torch::Tensor rgb = photo.contiguous();
    std::copy(rgb.data_ptr<float>(), rgb.data_ptr<float>() + rgb.numel(), canvas.pixels.begin());
    for (const auto& f : faces) {
      const int r = std::max(1, int(std::lround(f.box.width / 100)));
      draw_box(canvas, f.box.x, f.box.y, f.box.width, f.box.height, {0.2f, 0.9f, 0.3f});
      draw_landmarks(canvas, f.points, {1.f, 0.2f, 0.2f}, r);
    }
    write_image(opt.draw, canvas);
  }
  write_file_atomic(opt.output, doc.dump(1) + "\n");
  spdlog::info("landmarks detect: {}: {} face(s), best score {:.3f}; {:.1f} ms on {} ({})", opt.photo, faces.size(),
               faces[0].score, ms, opt.device_name, opt.output);
}

void ScanLandmarkFilesOptions::check() const {
  if (!uncalibrated.empty() && calibration.empty())
    throw InvalidInput("--uncalibrated", "needs --calibration (the points before it)", "pass --calibration FILE");
  if (multiview.views == 1 && !(calibration.empty() && save_views.empty() && capture.empty()))
    throw InvalidInput("--views", "--calibration, --capture and --save-views need several views", "pass --views 16");
  if (!sparse.empty() && capture.empty())
    throw InvalidInput("--sparse", "needs --capture (the photos the model was made from)", "pass --capture DIR");
  detect.check();
  multiview.check();
  if (!capture.empty()) CaptureLandmarkOptions{capture, sparse, colmap}.check();
}

void scan_landmark_files(ScanLandmarkFilesOptions o) {
  o.check();
  check_output_file(o.output);
  if (!o.uncalibrated.empty()) check_output_file(o.uncalibrated);
  if (o.weights.empty()) o.weights = default_face_api_folder();
  const TexturedScan scan = read_textured_scan(o.scan, o.texture);
  const Mesh& mesh = scan.mesh;
  const Image* diffuse = scan.diffuse ? &*scan.diffuse : nullptr;
  const std::string& mesh_path = scan.mesh_path;
  FaceApi net(o.weights);
  if (o.multiview.views > 1) {
    o.multiview.triangulate.jaw = !o.no_jaw;
    o.multiview.refinements = o.detect.refinements;
    std::optional<LandmarkCalibration> calibration;
    if (!o.calibration.empty()) calibration = read_landmark_calibration(o.calibration);
    auto m = detect_multiview_landmarks(net, mesh, diffuse, o.multiview, !o.draw.empty() || !o.save_views.empty());
    if (!o.save_views.empty()) {
      std::vector<Camera> cameras;
      for (const auto& v : m.views) cameras.push_back(v.camera);
      write_capture_folder(o.save_views, "view", m.pictures, cameras);
    }
    nlohmann::json capture_info;
    if (!o.capture.empty()) capture_info = capture_landmarks(net, mesh, m, {o.capture, o.sparse, o.colmap}, o.multiview);
    if (!o.uncalibrated.empty()) write_file_atomic(o.uncalibrated, multiview_landmarks_json(m.result));
    if (calibration) apply_calibration(mesh, *calibration, m.result);
    if (!o.draw.empty() && !m.pictures.empty()) write_image(o.draw, draw_multiview(m));
    nlohmann::json doc = nlohmann::json::parse(multiview_landmarks_json(m.result));
    if (!capture_info.is_null()) doc["capture"] = capture_info;
    write_file_atomic(o.output, doc.dump(1) + "\n");
    int valid = 0;
    for (const auto& p : m.result.points) valid += p.valid;
    spdlog::info("landmarks scan: {}: {} of {} views with a face, {} of 68 points triangulated; render {:.1f} s, "
                 "detect {:.1f} s, triangulate {:.2f} s -> {}", mesh_path, m.result.views_detected, m.result.views,
                 valid, m.seconds_render, m.seconds_detect, m.seconds_triangulate, o.output);
    return;
  }
  const auto r = detect_scan_landmarks(net, mesh, diffuse, o.detect);
  if (!o.draw.empty()) {
    Image canvas = r.picture;
    draw_landmarks(canvas, r.px, {1.f, 0.2f, 0.2f}, std::max(1, o.detect.size / 256));
    write_image(o.draw, canvas);
  }
  write_landmarks(o.output, r.landmarks);
  spdlog::info("landmarks scan: {}: detector score {:.3f}{}, {} point(s) snapped onto the silhouette -> {}", mesh_path,
               r.detector_score, r.detector_score == 0 ? " (none: coverage box used)" : "", r.off_surface, o.output);
}

ScanLandmarkDetector face_api_scan_detector(const std::string& calibration_path) {
  std::optional<LandmarkCalibration> calibration;
  if (!calibration_path.empty()) calibration = read_landmark_calibration(calibration_path);
  return [calibration](const Mesh& scan, const Image* diffuse) {
    static const FaceApi net(default_face_api_folder());  // loaded on the first scan that needs it
    DetectedLandmarks out;
    if (!calibration) {  // the front render (scan_landmarks.h)
      const ScanLandmarks found = detect_scan_landmarks(net, scan, diffuse);
      out.landmarks = found.landmarks;
      out.detector_score = found.detector_score;
      out.snapped_to_silhouette = found.off_surface;
      return out;
    }
    auto found = detect_multiview_landmarks(net, scan, diffuse, MultiviewOptions{});
    apply_calibration(scan, *calibration, found.result);
    out.landmarks = found.result.landmarks;
    for (const auto& v : found.views) out.detector_score = std::max(out.detector_score, v.score);
    out.views = found.result.views;
    out.calibrated = true;
    for (const auto& p : found.result.points) out.sigma_mm.push_back(p.sigma_mm);
    return out;
  };
}

PhotoDetector face_api_photo_detector(int input_size) {
  auto net = std::make_shared<const FaceApi>(default_face_api_folder());
  return [net, input_size](const Image& photo) {
    DetectOptions options;
    options.input_size = input_size;
    std::vector<PhotoFace> faces;
    for (const Face& f : net->detect(photo_tensor(photo, "photo"), options)) faces.push_back({f.score, f.points});
    return faces;
  };
}

}  // namespace bareskin::detect
