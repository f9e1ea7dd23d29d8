// bareskin landmarks detect: faces and their iBUG-68 landmarks in a photo, with face-api's networks in LibTorch
// (detect/face_api.h). The output is a landmark file every other command reads (the best face's points), plus
// every face found with its box and score.
#include <chrono>
#include <algorithm>
#include <filesystem>
#include <optional>
#include <thread>
#include <memory>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "detect/face_api.h"
#include "detect/multiview_landmarks.h"
#include "detect/scan_landmarks.h"
#include "scan/capture.h"
#include "scan/colmap.h"
#include "render/preview.h"

namespace bareskin::cli {

void set_torch_threads(const Globals& globals) {
  // LibTorch defaults to the physical cores (1 on a 2-vCPU machine); follow --threads like the thread pool does.
  torch::set_num_threads(globals.threads > 0 ? globals.threads : int(std::thread::hardware_concurrency()));
}

ScanLandmarkDetector scan_landmark_detector(const Globals& globals, const std::string& calibration_path) {
  set_torch_threads(globals);
  std::optional<LandmarkCalibration> calibration;
  if (!calibration_path.empty()) calibration = read_landmark_calibration(calibration_path);
  return [calibration](const Mesh& scan, const Image* diffuse) {
    static const detect::FaceApi net(detect::default_face_api_folder());
    DetectedLandmarks out;
    if (!calibration) {  // the front render (detect/scan_landmarks.h)
      const detect::ScanLandmarks found = detect::detect_scan_landmarks(net, scan, diffuse);
      out.landmarks = found.landmarks;
      out.detector_score = found.detector_score;
      out.snapped_to_silhouette = found.off_surface;
      return out;
    }
    auto found = detect::detect_multiview_landmarks(net, scan, diffuse, detect::MultiviewOptions{});
    apply_calibration(scan, *calibration, found.result);
    out.landmarks = found.result.landmarks;
    for (const auto& v : found.views) out.detector_score = std::max(out.detector_score, v.score);
    out.views = found.result.views;
    out.calibrated = true;
    for (const auto& p : found.result.points) out.sigma_mm.push_back(p.sigma_mm);
    return out;
  };
}

detect::PhotoDetector photo_detector(const Globals& globals, int input_size) {
  set_torch_threads(globals);
  auto net = std::make_shared<const detect::FaceApi>(detect::default_face_api_folder());
  return [net, input_size](const Image& photo) {
    detect::DetectOptions options;
    options.input_size = input_size;
    std::vector<detect::PhotoFace> faces;
    for (const detect::Face& f : net->detect(detect::photo_tensor(photo, "photo"), options))
      faces.push_back({f.score, f.points});
    return faces;
  };
}

namespace {

// A scan folder (mesh.obj|ply + diffuse.png|exr|tif) or a mesh file with an optional texture.
Mesh read_textured_scan(const std::string& scan, const std::string& texture_given, std::string& mesh_path,
                        std::optional<Image>& diffuse) {
  mesh_path = scan;
  std::string texture = texture_given;
  if (std::filesystem::is_directory(scan)) {
    mesh_path.clear();
    for (const char* name : {"mesh.obj", "mesh.ply"})
      if (std::filesystem::exists(scan + "/" + name)) mesh_path = scan + "/" + name;
    if (mesh_path.empty()) throw InvalidInput(scan, "holds no mesh.obj or mesh.ply", "pass a scan folder");
    for (const char* name : {"diffuse.png", "diffuse.exr", "diffuse.tif", "diffuse.tiff"})
      if (texture.empty() && std::filesystem::exists(scan + "/" + name)) texture = scan + "/" + name;
  }
  Mesh mesh = read_mesh(mesh_path);
  if (!texture.empty()) diffuse = to_linear(read_image(texture));
  if (diffuse && !mesh.has_uv()) throw InvalidInput(mesh_path, "has no UVs for its diffuse map", "pass --texture ''");
  return mesh;
}

void save_views(const std::string& dir, const detect::MultiviewScanLandmarks& m) {
  std::vector<Camera> cameras;
  for (const auto& v : m.views) cameras.push_back(v.camera);
  write_capture_folder(dir, "view", m.pictures, cameras);
}

// landmarks capture: a synthetic rig capture of a scan (scan/capture.h), photo_NN.png + cameras.json.
void run_synthetic_capture(const Mesh& mesh, const Image* diffuse, const std::string& dir, const CaptureOptions& o) {
  const Eigen::Vector3d target = (mesh.V.colwise().minCoeff() + mesh.V.colwise().maxCoeff()).transpose() / 2;
  const std::vector<Camera> cameras = capture_cameras(o, target);
  std::vector<Image> photos;
  const auto start = std::chrono::steady_clock::now();
  for (size_t k = 0; k < cameras.size(); ++k)
    photos.push_back(render_capture_photo(mesh, diffuse, cameras[k], target, o, int(k)));
  write_capture_folder(dir, "photo", photos, cameras);
  spdlog::info("landmarks capture: {} photos of {}² px ({}x supersampled{}) in {:.1f} s -> {}", photos.size(), o.size,
               o.supersample, o.backdrop ? ", speckle backdrop" : "",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), dir);
}

// --capture: the photos' cameras from COLMAP (or --sparse), brought onto the scan (a similarity from the landmarks
// triangulated in both frames, then ICP of the model's points against the mesh), and the landmarks triangulated on
// the photos; m.result is replaced. When COLMAP cannot reconstruct the folder, one warning names the fallback (the
// virtual views already in m) and null is returned.
nlohmann::json capture_landmarks(const detect::FaceApi& net, const Mesh& mesh, detect::MultiviewScanLandmarks& m,
                                 const std::string& capture, const std::string& sparse,
                                 const detect::MultiviewOptions& options, const ColmapOptions& colmap) {
  if (!std::filesystem::is_directory(capture)) throw InvalidInput(capture, "is not a folder", "pass the photos' folder");
  int photos = 0;
  for (const auto& e : std::filesystem::directory_iterator(capture)) {
    const std::string ext = lower_extension(e.path().string());
    photos += ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
  }
  ColmapModel model;
  if (!sparse.empty()) {
    model = read_colmap_text_model(sparse);
  } else {
    const std::string work = (std::filesystem::temp_directory_path() /
                              ("bareskin_colmap_" + std::to_string(std::hash<std::string>{}(capture) % 1000000)))
                                 .string();
    std::filesystem::remove_all(work);
    std::filesystem::remove(work + ".log");
    // COLMAP's database and models are removed once read; its log stays (named in the messages).
    try {
      model = run_colmap(capture, work, colmap, work + ".log");
      std::filesystem::remove_all(work);
    } catch (const Error& e) {
      std::filesystem::remove_all(work);
      spdlog::warn("landmarks scan: {}; falling back to the {} virtual views of the scan", e.what(), options.views);
      return nullptr;
    }
  }
  std::vector<LandmarkView> views;
  for (const ColmapImage& im : model.images)
    views.push_back(detect::detect_view(net, read_image(capture + "/" + im.name), im.camera, options.refinements,
                                        options.triangulate.min_score));
  // The start: landmarks 17-67 in the model's frame (photos) against the scan's (virtual views).
  Eigen::MatrixX3d in_model = triangulate_free(views, options.triangulate.pixel_sigma, options.triangulate.min_score);
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
                    {"t", {c.t.x(), c.t.y(), c.t.z()}}, {"score", views[v].score}});
  }
  m.result = triangulate_landmarks(mesh, views, options.triangulate);
  m.views = views;
  m.pictures.clear();
  spdlog::info("landmarks scan: {}: COLMAP registered {} of {} photos, {} points ({} on the head), reprojection "
               "{:.2f} px; aligned to the scan (scale {:.4g}, ICP RMS {:.2f} mm over the best 80%)", capture,
               model.images.size(), photos, model.points.rows(), on_head, model.reprojection_px, S.s, rms);
  return {{"photos", photos}, {"registered", model.images.size()}, {"points", model.points.rows()},
          {"points_on_head", on_head}, {"reprojection_px", model.reprojection_px}, {"scale", S.s},
          {"icp_rms_mm", rms}, {"median_features", model.median_features}, {"verified_pairs", model.verified_pairs},
          {"cameras", cams}};
}

void run_landmarks_calibrate(const std::string& scans, const std::string& output, int count,
                             const detect::MultiviewOptions& options, const std::string& weights) {
  std::vector<std::string> dirs;
  if (!std::filesystem::is_directory(scans)) throw InvalidInput(scans, "is not a folder", "pass a folder of scan folders");
  for (const auto& e : std::filesystem::directory_iterator(scans))
    if (e.is_directory() && std::filesystem::exists(e.path() / "landmarks.json")) dirs.push_back(e.path().string());
  std::sort(dirs.begin(), dirs.end());
  if (count > 0 && int(dirs.size()) > count) dirs.resize(size_t(count));
  if (dirs.size() < 2)
    throw InvalidInput(scans, "holds " + std::to_string(dirs.size()) + " scan folder(s) with landmarks.json",
                       "a calibration needs two or more scans with known 3D landmarks");
  const detect::FaceApi net(weights);
  std::vector<MultiviewLandmarks> found;
  std::vector<Landmarks> truth;
  for (const std::string& dir : dirs) {
    std::string mesh_path;
    std::optional<Image> diffuse;
    const Mesh mesh = read_textured_scan(dir, "", mesh_path, diffuse);
    truth.push_back(read_landmarks(dir + "/landmarks.json"));
    if (truth.back().points.rows() != 68 || truth.back().points.cols() != 3)
      throw InvalidInput(dir + "/landmarks.json", "needs 68 3D points", "give the scan's iBUG-68 landmarks in mm");
    found.push_back(detect::detect_multiview_landmarks(net, mesh, diffuse ? &*diffuse : nullptr, options).result);
    spdlog::info("landmarks calibrate: {}: {} of {} views with a face", dir, found.back().views_detected, options.views);
  }
  const LandmarkCalibration c = calibrate_landmarks(found, truth);
  write_file_atomic(output, landmark_calibration_json(c));
  std::vector<double> best;
  for (int i = 17; i < 68; ++i) best.push_back(std::min(c.spread_detected_mm[i], c.spread_shape_mm[i]));
  std::nth_element(best.begin(), best.begin() + 25, best.end());
  spdlog::info("landmarks calibrate: {} scans, leave-one-out median error over 17-67 {:.2f} mm -> {}", dirs.size(),
               best[25], output);
}

}  // namespace

std::function<void()> setup_landmarks_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string photo, output, draw, weights, device = "cpu";
    detect::DetectOptions detect;
  };
  auto opt = std::make_shared<Options>();
  app.require_subcommand(1);
  CLI::App* d = app.add_subcommand("detect", "Find faces and their 68 landmarks in a photo (face-api's networks)");
  d->add_option("photo", opt->photo, "Photo (PNG, JPEG, TIFF, EXR; grey, RGB or RGBA; 8/16-bit or float)")->required();
  d->add_option("-o,--output", opt->output, "Landmark JSON: the best face's 68 points (px) as 'points', every face "
                                            "under 'faces' with 'box' [x, y, w, h] and 'score'")
      ->required();
  d->add_option("--draw", opt->draw, "Also write the photo with boxes and landmarks drawn (PNG/JPEG)");
  d->add_option("--weights", opt->weights, "Folder with face-api's tfjs models (default: face_api/ in the assets, "
                                          "docs/cli.md)");
  d->add_option("--input-size", opt->detect.input_size, "Detector input size (multiple of 32): larger finds smaller faces")
      ->capture_default_str();
  d->add_option("--min-score", opt->detect.min_score, "Drop detections scoring below")->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  d->add_option("--max-faces", opt->detect.max_faces, "Keep at most this many faces (0: all)")->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  d->add_option("--device", opt->device, "cpu or cuda")->capture_default_str()->check(CLI::IsMember({"cpu", "cuda"}));

  struct ScanOptions {
    std::string scan, texture, output, draw, weights;
    detect::ScanLandmarkOptions detect;
    detect::MultiviewOptions multiview;
    bool no_jaw = false;
    std::string calibration, uncalibrated, save_views, capture, sparse;
    ColmapOptions colmap;
  };
  auto sc = std::make_shared<ScanOptions>();
  sc->multiview.views = 1;
  CLI::App* s = app.add_subcommand("scan", "3D landmarks of a textured scan: detected in its front render, back-projected");
  s->add_option("scan", sc->scan, "Scan folder (mesh.obj|ply + diffuse.png|exr|tif) or a mesh file")->required();
  s->add_option("--texture", sc->texture, "Diffuse map, when the scan is a mesh file (else: grey)");
  s->add_option("-o,--output", sc->output, "3D landmark JSON (mm), as scan/landmarks.json")->required();
  s->add_option("--draw", sc->draw, "Also write the front render with the 2D landmarks drawn (PNG)");
  s->add_option("--weights", sc->weights, "Folder with face-api's tfjs models (default: face_api/ in the assets)");
  s->add_option("--size", sc->detect.size, "Render size")->capture_default_str()->check(CLI::Range(128, 4096));
  s->add_option("--refinements", sc->detect.refinements, "Landmark passes on the box the previous points imply")
      ->capture_default_str()->check(CLI::Range(0, 10));
  s->add_option("--views", sc->multiview.views, "Virtual cameras around the face, landmarks triangulated (Ceres); 1: "
                                                "the single front render, back-projected")
      ->capture_default_str()->check(CLI::Range(1, 100));
  s->add_option("--view-size", sc->multiview.size, "Render size per view (with --views > 1)")->capture_default_str()
      ->check(CLI::Range(128, 4096));
  s->add_option("--pixel-sigma", sc->multiview.triangulate.pixel_sigma, "Detector noise in px (the robust loss's scale)")
      ->capture_default_str()->check(CLI::Range(0.1, 100.0));
  s->add_flag("--no-jaw", sc->no_jaw, "Leave the jaw contour (0-16, silhouette-dependent) out: null points");
  s->add_option("--calibration", sc->calibration, "Landmark calibration (`landmarks calibrate`): the detector's "
                                                  "convention mapped onto the template's landmarks");
  s->add_option("--uncalibrated", sc->uncalibrated, "With --calibration: also write the points before it (JSON)");
  s->add_option("--capture", sc->capture, "The rig's photos of this scan: cameras from COLMAP, aligned to the scan, "
                                          "landmarks triangulated on the photos (fallback: the virtual views)");
  s->add_option("--sparse", sc->sparse, "With --capture: an existing COLMAP TXT model of the photos instead of running "
                                        "COLMAP");
  s->add_option("--colmap-features", sc->colmap.max_features, "With --capture: SIFT features per photo")
      ->capture_default_str()->check(CLI::Range(100, 100000))->group("COLMAP");
  s->add_option("--colmap-peak", sc->colmap.peak_threshold, "With --capture: SIFT peak threshold (lower: more "
                                                            "features on faint texture)")
      ->capture_default_str()->check(CLI::Range(0.0001, 0.1))->group("COLMAP");
  s->add_flag("--colmap-dsp", sc->colmap.domain_size_pooling, "With --capture: DSP-SIFT descriptors")->group("COLMAP");
  s->add_option("--colmap-focal", sc->colmap.focal_px, "With --capture: the rig's focal length in px, COLMAP's starting "
                                                       "value (default: EXIF, else COLMAP's guess)")
      ->check(CLI::PositiveNumber)->group("COLMAP");
  s->add_option("--save-views", sc->save_views, "Also write the views (view_NN.png) and their cameras (cameras.json) to "
                                                "this folder: a synthetic capture");

  struct CalibrateOptions {
    std::string scans, output, weights;
    detect::MultiviewOptions multiview;
    int count = 0;
  };
  auto ca = std::make_shared<CalibrateOptions>();
  CLI::App* c = app.add_subcommand("calibrate", "Learn the detector's landmark convention against known 3D landmarks "
                                                "(scan folders with landmarks.json) for `landmarks scan --calibration`");
  c->add_option("--scans", ca->scans, "Folder of scan folders (mesh, diffuse map, landmarks.json)")->required();
  c->add_option("-o,--output", ca->output, "Calibration JSON")->required();
  c->add_option("--count", ca->count, "Use the first N scans (0: all)")->capture_default_str()->check(CLI::NonNegativeNumber);
  c->add_option("--views", ca->multiview.views, "Virtual cameras (as landmarks scan)")->capture_default_str()
      ->check(CLI::Range(2, 100));
  c->add_option("--view-size", ca->multiview.size, "Render size per view")->capture_default_str()->check(CLI::Range(128, 4096));
  c->add_option("--weights", ca->weights, "Folder with face-api's tfjs models (default: face_api/ in the assets)");

  struct SyntheticCaptureOptions {
    std::string scan, texture, output;
    CaptureOptions capture;
    bool no_backdrop = false;
  };
  auto cp = std::make_shared<SyntheticCaptureOptions>();
  CLI::App* p = app.add_subcommand("capture", "Render a synthetic rig capture of a textured scan (photos from rows of "
                                              "cameras, speckle backdrop) for `landmarks scan --capture`");
  p->add_option("scan", cp->scan, "Scan folder (mesh.obj|ply + diffuse.png|exr|tif) or a mesh file")->required();
  p->add_option("--texture", cp->texture, "Diffuse map, when the scan is a mesh file (else: grey)");
  p->add_option("-o,--output", cp->output, "Folder for photo_NN.png and cameras.json (the true cameras)")->required();
  p->add_option("--photos", cp->capture.photos, "Cameras (3 rows from 12 on)")->capture_default_str();
  p->add_option("--size", cp->capture.size, "Photo size, px")->capture_default_str();
  p->add_option("--field", cp->capture.field_mm, "Width seen at the face, mm")->capture_default_str();
  p->add_option("--max-yaw", cp->capture.max_yaw_deg, "Rows span yaw in [-max, max] degrees")->capture_default_str();
  p->add_option("--max-pitch", cp->capture.max_pitch_deg, "Rows at pitch -max, 0, max degrees")->capture_default_str();
  p->add_option("--supersample", cp->capture.supersample, "Render at this multiple, then box-filter")->capture_default_str();
  p->add_option("--noise", cp->capture.noise, "Sensor noise sigma (linear)")->capture_default_str();
  p->add_option("--seed", cp->capture.seed, "Backdrop pattern and noise")->capture_default_str();
  p->add_flag("--no-backdrop", cp->no_backdrop, "Black behind the head instead of the speckle backdrop");

  return [opt, sc, s, ca, c, cp, p, &globals] {
    set_torch_threads(globals);
    if (p->parsed()) {
      cp->capture.backdrop = !cp->no_backdrop;
      cp->capture.check();
      std::string mesh_path;
      std::optional<Image> diffuse;
      const Mesh mesh = read_textured_scan(cp->scan, cp->texture, mesh_path, diffuse);
      run_synthetic_capture(mesh, diffuse ? &*diffuse : nullptr, cp->output, cp->capture);
      return;
    }
    if (c->parsed()) {
      run_landmarks_calibrate(ca->scans, ca->output, ca->count, ca->multiview,
                              ca->weights.empty() ? detect::default_face_api_folder() : ca->weights);
      return;
    }
    if (s->parsed()) {
      if (sc->weights.empty()) sc->weights = detect::default_face_api_folder();
      std::string mesh_path;
      std::optional<Image> diffuse;
      const Mesh mesh = read_textured_scan(sc->scan, sc->texture, mesh_path, diffuse);
      detect::FaceApi net(sc->weights);
      if (sc->multiview.views == 1 && !(sc->calibration.empty() && sc->save_views.empty() && sc->capture.empty()))
        throw InvalidInput("--views", "--calibration, --capture and --save-views need several views", "pass --views 16");
      if (!sc->sparse.empty() && sc->capture.empty())
        throw InvalidInput("--sparse", "needs --capture (the photos the model was made from)", "pass --capture DIR");
      sc->colmap.threads = globals.threads;
      if (sc->multiview.views > 1) {
        sc->multiview.triangulate.jaw = !sc->no_jaw;
        sc->multiview.refinements = sc->detect.refinements;
        std::optional<LandmarkCalibration> calibration;
        if (!sc->calibration.empty()) calibration = read_landmark_calibration(sc->calibration);
        auto m = detect::detect_multiview_landmarks(net, mesh, diffuse ? &*diffuse : nullptr, sc->multiview,
                                                    !sc->draw.empty() || !sc->save_views.empty());
        if (!sc->save_views.empty()) save_views(sc->save_views, m);
        nlohmann::json capture_info;
        if (!sc->capture.empty())
          capture_info = capture_landmarks(net, mesh, m, sc->capture, sc->sparse, sc->multiview, sc->colmap);
        if (!sc->uncalibrated.empty()) write_file_atomic(sc->uncalibrated, multiview_landmarks_json(m.result));
        if (calibration) apply_calibration(mesh, *calibration, m.result);
        if (!sc->draw.empty() && !m.pictures.empty()) write_image(sc->draw, detect::draw_multiview(m));
        nlohmann::json doc = nlohmann::json::parse(multiview_landmarks_json(m.result));
        if (!capture_info.is_null()) doc["capture"] = capture_info;
        write_file_atomic(sc->output, doc.dump(1) + "\n");
        int valid = 0;
        for (const auto& p : m.result.points) valid += p.valid;
        spdlog::info("landmarks scan: {}: {} of {} views with a face, {} of 68 points triangulated; render {:.1f} s, "
                     "detect {:.1f} s, triangulate {:.2f} s -> {}", mesh_path, m.result.views_detected, m.result.views,
                     valid, m.seconds_render, m.seconds_detect, m.seconds_triangulate, sc->output);
        return;
      }
      const auto r = detect::detect_scan_landmarks(net, mesh, diffuse ? &*diffuse : nullptr, sc->detect);
      if (!sc->draw.empty()) {
        Image canvas = r.picture;
        draw_landmarks(canvas, r.px, {1.f, 0.2f, 0.2f}, std::max(1, sc->detect.size / 256));
        write_image(sc->draw, canvas);
      }
      write_landmarks(sc->output, r.landmarks);
      spdlog::info("landmarks scan: {}: detector score {:.3f}{}, {} point(s) snapped onto the silhouette -> {}", mesh_path,
                   r.detector_score, r.detector_score == 0 ? " (none: coverage box used)" : "", r.off_surface,
                   sc->output);
      return;
    }
    if (opt->device == "cuda" && !torch::cuda::is_available())
      throw InvalidInput("--device", "cuda was asked for but no CUDA device is available", "use --device cpu");
    for (const std::string& out : {opt->output, opt->draw}) {
      if (!out.empty() && out == opt->photo) throw InvalidInput(out, "would overwrite the photo", "pick another name");
    }
    if (lower_extension(opt->output) != ".json")
      throw InvalidInput(opt->output, "landmarks are written as JSON", "name the output *.json");
    if (opt->weights.empty()) opt->weights = detect::default_face_api_folder();
    detect::FaceApi net(opt->weights);
    if (opt->device == "cuda") net.to(torch::kCUDA);
    const Image image = read_image(opt->photo);
    const torch::Tensor photo = detect::photo_tensor(image, opt->photo);
    const auto start = std::chrono::steady_clock::now();
    const auto faces = net.detect(photo, opt->detect);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    if (faces.empty())
      throw InvalidInput(opt->photo, "no face found with score above " + std::to_string(opt->detect.min_score),
                         "try a lower --min-score or a larger --input-size, or crop the photo around the face");

    auto points_json = [](const Eigen::Matrix<double, 68, 2>& p) {
      auto a = nlohmann::json::array();
      for (int i = 0; i < 68; ++i) a.push_back({p(i, 0), p(i, 1)});
      return a;
    };
    nlohmann::json doc = {{"scheme", "ibug68"}, {"units", "px"}, {"image", opt->photo},
                          {"width", image.width},  {"height", image.height}};
    doc["points"] = points_json(faces[0].points);
    doc["score"] = faces[0].score;
    doc["faces"] = nlohmann::json::array();
    for (const auto& f : faces)
      doc["faces"].push_back({{"score", f.score},
                              {"box", {f.box.x, f.box.y, f.box.width, f.box.height}},
                              {"points", points_json(f.points)}});
    doc["detector"] = {{"model", "face-api 1.7.15 tiny_face_detector + face_landmark_68"},
                       {"input_size", opt->detect.input_size},
                       {"min_score", opt->detect.min_score},
                       {"device", opt->device}};

    std::string drawn;
    if (!opt->draw.empty()) {
      Image canvas(image.width, image.height, 3, ColorSpace::sRGB);
      const torch::Tensor rgb = photo.contiguous();
      std::copy(rgb.data_ptr<float>(), rgb.data_ptr<float>() + rgb.numel(), canvas.pixels.begin());
      for (const auto& f : faces) {
        const int r = std::max(1, int(std::lround(f.box.width / 100)));
        draw_box(canvas, f.box.x, f.box.y, f.box.width, f.box.height, {0.2f, 0.9f, 0.3f});
        draw_landmarks(canvas, f.points, {1.f, 0.2f, 0.2f}, r);
      }
      write_image(opt->draw, canvas);
    }
    write_file_atomic(opt->output, doc.dump(1) + "\n");
    spdlog::info("landmarks detect: {}: {} face(s), best score {:.3f}; {:.1f} ms on {} ({})", opt->photo, faces.size(), faces[0].score, ms,
              opt->device, opt->output);
  };
}

}  // namespace bareskin::cli
