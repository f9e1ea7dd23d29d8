// bareskin landmarks detect: faces and their iBUG-68 landmarks in a photo, with face-api's networks in LibTorch
// (detect/face_api.h). The output is a landmark file every other command reads (the best face's points), plus
// every face found with its box and score.
#include <algorithm>
#include <chrono>
#include <memory>
#include <optional>
#include <thread>
#include <nlohmann/json.hpp>
#include <torch/torch.h>

#include "apps/cli.h"
#include "apps/device_flag.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/scan_folder.h"
#include "detect/capture_landmarks.h"
#include "detect/face_api.h"
#include "detect/multiview_landmarks.h"
#include "detect/scan_landmarks.h"
#include "render/preview.h"
#include "scan/capture.h"
#include "training/device.h"

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

void save_views(const std::string& dir, const detect::MultiviewScanLandmarks& m) {
  std::vector<Camera> cameras;
  for (const auto& v : m.views) cameras.push_back(v.camera);
  write_capture_folder(dir, "view", m.pictures, cameras);
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
      ->check(CLI::Range(0, 100000));
  add_device_option(*d, opt->device);

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
  s->add_option("--colmap-focal", sc->colmap.focal_px, "With --capture: the rig's calibrated focal length in px, held "
                                                       "fixed (default: EXIF, else COLMAP's guess, refined)")
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
  c->add_option("--count", ca->count, "Use the first N scans (0: all)")->capture_default_str()->check(CLI::Range(0, 1000000));
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
  p->add_option("--photos", cp->capture.photos, "Cameras, at least 2 (in 3 rows from 12 on)")->capture_default_str();
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
      check_output_apart(cp->output, {cp->scan, cp->texture});
      const TexturedScan scan = read_textured_scan(cp->scan, cp->texture);
      write_synthetic_capture(scan.mesh, scan.diffuse ? &*scan.diffuse : nullptr, cp->output, cp->capture);
      return;
    }
    if (c->parsed()) {
      check_output_file(ca->output);
      check_output_apart(ca->output, {ca->scans});
      const detect::FaceApi net(ca->weights.empty() ? detect::default_face_api_folder() : ca->weights);
      write_file_atomic(ca->output,
                        landmark_calibration_json(detect::calibrate_on_scans(net, ca->scans, ca->count, ca->multiview)));
      spdlog::info("landmarks calibrate: -> {}", ca->output);
      return;
    }
    if (s->parsed()) {
      check_output_file(sc->output);
      if (!sc->uncalibrated.empty() && sc->calibration.empty())
        throw InvalidInput("--uncalibrated", "needs --calibration (the points before it)", "pass --calibration FILE");
      if (!sc->uncalibrated.empty()) check_output_file(sc->uncalibrated);
      if (sc->weights.empty()) sc->weights = detect::default_face_api_folder();
      const TexturedScan scan = read_textured_scan(sc->scan, sc->texture);
      const Mesh& mesh = scan.mesh;
      const Image* diffuse = scan.diffuse ? &*scan.diffuse : nullptr;
      const std::string& mesh_path = scan.mesh_path;
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
        auto m = detect::detect_multiview_landmarks(net, mesh, diffuse, sc->multiview,
                                                    !sc->draw.empty() || !sc->save_views.empty());
        if (!sc->save_views.empty()) save_views(sc->save_views, m);
        nlohmann::json capture_info;
        if (!sc->capture.empty())
          capture_info = detect::capture_landmarks(net, mesh, m, {sc->capture, sc->sparse, sc->colmap}, sc->multiview);
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
      const auto r = detect::detect_scan_landmarks(net, mesh, diffuse, sc->detect);
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
    const torch::Device device = parse_device(opt->device);
    for (const std::string& out : {opt->output, opt->draw}) {
      if (!out.empty() && out == opt->photo) throw InvalidInput(out, "would overwrite the photo", "pick another name");
    }
    if (lower_extension(opt->output) != ".json")
      throw InvalidInput(opt->output, "landmarks are written as JSON", "name the output *.json");
    if (opt->weights.empty()) opt->weights = detect::default_face_api_folder();
    detect::FaceApi net(opt->weights);
    net.to(device);
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
