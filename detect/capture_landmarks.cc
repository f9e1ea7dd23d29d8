#include "detect/capture_landmarks.h"

#include <algorithm>
#include <filesystem>
#include <fmt/format.h>
#include <functional>
#include <cmath>
#include <limits>
#include <optional>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/stats.h"

namespace bareskin::detect {

namespace {

// The capture's camera model: the user's sparse model, or COLMAP run on the photos (its database and models removed
// once read; its log stays, named in the messages). Nullopt, after one warning naming the fallback, when COLMAP
// reconstructs nothing.
std::optional<ColmapModel> capture_model(const CaptureLandmarkOptions& c, int views) {
  if (!c.sparse.empty()) return read_colmap_text_model(c.sparse);
  const std::string work = (std::filesystem::temp_directory_path() /
                            ("bareskin_colmap_" + std::to_string(std::hash<std::string>{}(c.photos) % 1000000)))
                               .string();
  std::filesystem::remove_all(work);
  std::filesystem::remove(work + ".log");
  try {
    ColmapModel model = run_colmap(c.photos, work, c.colmap, work + ".log");
    std::filesystem::remove_all(work);
    return model;
  } catch (const Error& e) {
    std::filesystem::remove_all(work);
    spdlog::warn("landmarks scan: {}; falling back to the {} virtual views of the scan", e.what(), views);
    return std::nullopt;
  }
}

// The model's frame on the scan's, and what it took.
struct CaptureAlignment {
  std::vector<LandmarkView> views;  // the photos' detections, cameras in the model's frame; dropped ones score 0
  std::vector<int> dropped;         // photos whose camera disagrees with the others
  Similarity S;
  double icp_rms_mm = 0;
  Eigen::Index on_head = 0;
  double landmark_gap_mm = 0;  // median over 17-67: the photos' landmarks, aligned, to the virtual views'
  double camera_nme = 0;  // the virtual views' landmarks through the aligned cameras (see camera_nme below)
};

// How far the cameras, moved onto the scan by `S`, are from where the photos say: the virtual views' landmarks 17-67
// (on the scan) projected through each photo's camera against that photo's detections, as a normalised mean error
// (each photo's median distance over its outer-eye-corner distance, 36-45), median over the photos. It needs no
// truth and looks at the cameras themselves: COLMAP's model can fit the head's points and its own landmarks well
// enough and still place the cameras tens of px off. On 16 synthetic 384² photos, the true cameras score 0.032
// (the detector's own noise) and cameras 20 mm off 0.13; the bound is 0.08.
constexpr double kMaxCameraNme = 0.08;
double camera_nme(const std::vector<LandmarkView>& views, const Similarity& S, const Eigen::MatrixX3d& on_scan,
                  double min_score) {
  std::vector<double> per_photo;
  const Eigen::Matrix<double, 68, 3> points = on_scan;
  for (const LandmarkView& v : views) {
    const double eyes = (v.px.row(36) - v.px.row(45)).norm();
    if (v.score < min_score || !(eyes > 0)) continue;
    const double px = median_landmark_reprojection_px(v, transform_camera(v.camera, S), points);
    if (!std::isnan(px)) per_photo.push_back(px / eyes);
  }
  return per_photo.empty() ? std::numeric_limits<double>::infinity() : median(per_photo);
}

// Detects the landmarks in each photo, leaves out photos whose camera disagrees with the others, and brings the
// model's frame onto the scan: a similarity from landmarks 17-67 (photos vs virtual views), then ICP of the model's
// head points (those within a tenth of the scan's `size` after the landmark start, which is good to a few mm: not the
// backdrop, floor or rig). Nullopt when too few landmarks are found on the photos.
std::optional<CaptureAlignment> align_capture(const FaceApi& net, const Mesh& mesh, double size,
                                              const Eigen::MatrixX3d& on_scan, const ColmapModel& model,
                                              const std::string& capture, const MultiviewOptions& options) {
  CaptureAlignment a;
  for (const ColmapImage& im : model.images)
    a.views.push_back(detect_view(net, read_image(capture + "/" + im.name), im.camera, options.refinements,
                                  options.triangulate.min_score));
  // The start: landmarks 17-67 in the model's frame (photos) against the scan's (virtual views).
  Eigen::MatrixX3d in_model = triangulate_free(a.views, options.triangulate.pixel_sigma, options.triangulate.min_score);
  // A photo COLMAP placed wrongly disagrees with the points the others triangulate: it takes no further part.
  a.dropped = inconsistent_views(a.views, in_model, options.triangulate.min_score);
  for (int v : a.dropped) {
    spdlog::warn("landmarks scan: {}/{}: its camera disagrees with the other photos (the landmarks they triangulate "
                 "project far from its detections): left out", capture, model.images[size_t(v)].name);
    a.views[size_t(v)].score = 0;
  }
  if (!a.dropped.empty())
    in_model = triangulate_free(a.views, options.triangulate.pixel_sigma, options.triangulate.min_score);
  in_model.topRows(17).setConstant(std::numeric_limits<double>::quiet_NaN());
  try {
    a.S = similarity_from_points(in_model, on_scan);
    const Eigen::MatrixX3d head = points_near_mesh(model.points, mesh, a.S, 0.1 * size);
    a.on_head = head.rows();
    a.S = align_points_to_mesh(head, mesh, a.S, 100, 0.2, &a.icp_rms_mm);
  } catch (const InvalidInput&) {
    return std::nullopt;
  }
  std::vector<double> gap;
  for (Eigen::Index i = 17; i < 68; ++i)
    if (in_model.row(i).allFinite() && on_scan.row(i).allFinite())
      gap.push_back((a.S.apply(in_model.row(i).transpose()) - on_scan.row(i).transpose()).norm());
  a.landmark_gap_mm = gap.empty() ? std::numeric_limits<double>::infinity() : median(gap);
  a.camera_nme = camera_nme(a.views, a.S, on_scan, options.triangulate.min_score);
  return a;
}

}  // namespace

void CaptureLandmarkOptions::check() const {
  if (photos.empty()) throw InvalidInput("--capture", "names no folder", "pass the rig's photos' folder");
  colmap.check();
}

nlohmann::json capture_landmarks(const FaceApi& net, const Mesh& mesh, MultiviewScanLandmarks& m,
                                 const CaptureLandmarkOptions& c, const MultiviewOptions& options) {
  c.check();
  options.check();
  const std::string& capture = c.photos;
  if (!std::filesystem::is_directory(capture)) throw InvalidInput(capture, "is not a folder", "pass the photos' folder");
  int photos = 0;
  for (const auto& e : std::filesystem::directory_iterator(capture)) {
    const std::string ext = lower_extension(e.path().string());
    photos += ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
  }
  const double size = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
  // A model is distorted when its aligned landmarks land far from the virtual views' (more than 5% of the scan's
  // size; they agree to 1-3 mm on a good one) or its cameras far from the photos (camera_nme above kMaxCameraNme):
  // COLMAP's mapping is not repeatable, so its own run gets one more try.
  const int tries = c.sparse.empty() ? 2 : 1;
  ColmapModel model;
  CaptureAlignment a;
  for (int attempt = 1;; ++attempt) {
    std::optional<ColmapModel> found = capture_model(c, options.views);
    if (!found) return nullptr;
    model = std::move(*found);
    std::optional<CaptureAlignment> aligned =
        align_capture(net, mesh, size, m.result.landmarks.points, model, capture, options);
    if (!aligned) {
      spdlog::warn("landmarks scan: {}: too few landmarks found on the photos to align COLMAP's model; falling back "
                   "to the {} virtual views of the scan", capture, options.views);
      return nullptr;
    }
    a = std::move(*aligned);
    if (a.landmark_gap_mm <= 0.05 * size && a.camera_nme <= kMaxCameraNme) break;
    const std::string why = fmt::format(
        "{}: once COLMAP's model is aligned to the scan (ICP RMS {:.2f} mm), the photos' landmarks land {:.1f} mm "
        "from the virtual views' and the virtual views' land {:.0f}% of the eye distance from the photos' "
        "detections through the cameras: the model is distorted",
        capture, a.icp_rms_mm, a.landmark_gap_mm, 100 * a.camera_nme);
    if (attempt >= tries) {
      spdlog::warn("landmarks scan: {}; falling back to the {} virtual views of the scan", why, options.views);
      return nullptr;
    }
    spdlog::warn("landmarks scan: {}; running COLMAP once more", why);
  }
  nlohmann::json cams = nlohmann::json::array();
  std::vector<LandmarkView>& views = a.views;
  for (size_t v = 0; v < views.size(); ++v) {
    views[v].camera = transform_camera(views[v].camera, a.S);
    const Camera& cam = views[v].camera;
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) R.push_back({cam.R(r, 0), cam.R(r, 1), cam.R(r, 2)});
    cams.push_back({{"image", model.images[v].name}, {"focal", cam.focal}, {"cx", cam.cx}, {"cy", cam.cy}, {"R", R},
                    {"t", {cam.t.x(), cam.t.y(), cam.t.z()}}, {"score", views[v].score},
                    {"dropped", std::count(a.dropped.begin(), a.dropped.end(), int(v)) > 0}});
  }
  m.result = triangulate_landmarks(mesh, views, options.triangulate);
  m.views = views;
  m.pictures.clear();
  spdlog::info("landmarks scan: {}: COLMAP registered {} of {} photos, {} points ({} on the head), reprojection "
               "{:.2f} px; aligned to the scan (scale {:.4g}, ICP RMS {:.2f} mm over the best 80%, landmarks {:.2f} mm "
               "from the virtual views', cameras' NME {:.3f})",
               capture, model.images.size(), photos, model.points.rows(), a.on_head, model.reprojection_px, a.S.s,
               a.icp_rms_mm, a.landmark_gap_mm, a.camera_nme);
  return {{"photos", photos}, {"registered", model.images.size()}, {"points", model.points.rows()},
          {"points_on_head", a.on_head}, {"cameras_dropped", a.dropped.size()},
          {"reprojection_px", model.reprojection_px}, {"scale", a.S.s}, {"icp_rms_mm", a.icp_rms_mm},
          {"landmark_gap_mm", a.landmark_gap_mm}, {"camera_nme", a.camera_nme},
          {"median_features", model.median_features}, {"verified_pairs", model.verified_pairs}, {"cameras", cams}};
}

}  // namespace bareskin::detect
