#include "detect/capture_landmarks.h"

#include <algorithm>
#include <filesystem>
#include <functional>
#include <limits>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"

namespace bareskin::detect {

nlohmann::json capture_landmarks(const FaceApi& net, const Mesh& mesh, MultiviewScanLandmarks& m,
                                 const CaptureLandmarkOptions& c, const MultiviewOptions& options) {
  const std::string& capture = c.photos;
  if (!std::filesystem::is_directory(capture)) throw InvalidInput(capture, "is not a folder", "pass the photos' folder");
  int photos = 0;
  for (const auto& e : std::filesystem::directory_iterator(capture)) {
    const std::string ext = lower_extension(e.path().string());
    photos += ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
  }
  ColmapModel model;
  if (!c.sparse.empty()) {
    model = read_colmap_text_model(c.sparse);
  } else {
    const std::string work = (std::filesystem::temp_directory_path() /
                              ("bareskin_colmap_" + std::to_string(std::hash<std::string>{}(capture) % 1000000)))
                                 .string();
    std::filesystem::remove_all(work);
    std::filesystem::remove(work + ".log");
    // COLMAP's database and models are removed once read; its log stays (named in the messages).
    try {
      model = run_colmap(capture, work, c.colmap, work + ".log");
      std::filesystem::remove_all(work);
    } catch (const Error& e) {
      std::filesystem::remove_all(work);
      spdlog::warn("landmarks scan: {}; falling back to the {} virtual views of the scan", e.what(), options.views);
      return nullptr;
    }
  }
  std::vector<LandmarkView> views;
  for (const ColmapImage& im : model.images)
    views.push_back(detect_view(net, read_image(capture + "/" + im.name), im.camera, options.refinements,
                                        options.triangulate.min_score));
  // The start: landmarks 17-67 in the model's frame (photos) against the scan's (virtual views).
  Eigen::MatrixX3d in_model = triangulate_free(views, options.triangulate.pixel_sigma, options.triangulate.min_score);
  // A photo COLMAP placed wrongly disagrees with the points the others triangulate: it takes no further part.
  const std::vector<int> dropped = inconsistent_views(views, in_model, options.triangulate.min_score);
  for (int v : dropped) {
    spdlog::warn("landmarks scan: {}/{}: its camera disagrees with the other photos (the landmarks they triangulate "
                 "project far from its detections): left out", capture, model.images[size_t(v)].name);
    views[size_t(v)].score = 0;
  }
  if (!dropped.empty())
    in_model = triangulate_free(views, options.triangulate.pixel_sigma, options.triangulate.min_score);
  Eigen::MatrixX3d on_scan = m.result.landmarks.points;
  in_model.topRows(17).setConstant(std::numeric_limits<double>::quiet_NaN());
  Similarity S;
  double rms = 0;
  Eigen::Index on_head = 0;
  try {
    S = similarity_from_points(in_model, on_scan);
    // ICP on the head's points only: those on a backdrop, floor or rig are dropped by their distance to the mesh
    // after the landmark start (a tenth of the scan's size: the start is good to a few mm).
    const double size = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
    const Eigen::MatrixX3d head = points_near_mesh(model.points, mesh, S, 0.1 * size);
    on_head = head.rows();
    S = align_points_to_mesh(head, mesh, S, 100, 0.2, &rms);
  } catch (const InvalidInput&) {
    spdlog::warn("landmarks scan: {}: too few landmarks found on the photos to align COLMAP's model; falling back to "
                 "the {} virtual views of the scan", capture, options.views);
    return nullptr;
  }
  nlohmann::json cams = nlohmann::json::array();
  for (size_t v = 0; v < views.size(); ++v) {
    views[v].camera = transform_camera(views[v].camera, S);
    const Camera& c = views[v].camera;
    nlohmann::json R = nlohmann::json::array();
    for (int r = 0; r < 3; ++r) R.push_back({c.R(r, 0), c.R(r, 1), c.R(r, 2)});
    cams.push_back({{"image", model.images[v].name}, {"focal", c.focal}, {"cx", c.cx}, {"cy", c.cy}, {"R", R},
                    {"t", {c.t.x(), c.t.y(), c.t.z()}}, {"score", views[v].score},
                    {"dropped", std::count(dropped.begin(), dropped.end(), int(v)) > 0}});
  }
  m.result = triangulate_landmarks(mesh, views, options.triangulate);
  m.views = views;
  m.pictures.clear();
  spdlog::info("landmarks scan: {}: COLMAP registered {} of {} photos, {} points ({} on the head), reprojection "
               "{:.2f} px; aligned to the scan (scale {:.4g}, ICP RMS {:.2f} mm over the best 80%)", capture,
               model.images.size(), photos, model.points.rows(), on_head, model.reprojection_px, S.s, rms);
  return {{"photos", photos}, {"registered", model.images.size()}, {"points", model.points.rows()},
          {"points_on_head", on_head}, {"cameras_dropped", dropped.size()}, {"reprojection_px", model.reprojection_px}, {"scale", S.s},
          {"icp_rms_mm", rms}, {"median_features", model.median_features}, {"verified_pairs", model.verified_pairs},
          {"cameras", cams}};
}

}  // namespace bareskin::detect
