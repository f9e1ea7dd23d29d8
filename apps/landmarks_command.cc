// bareskin landmarks detect / scan / calibrate / capture: a photo's or a scan's landmarks with face-api's networks in
// LibTorch (detect/landmark_files.h), the detector's calibration, a synthetic rig capture; and the detectors the
// geometry commands take (apps/detector.h).
#include <memory>
#include <thread>
#include <torch/torch.h>

#include "apps/cli.h"
#include "apps/device_flag.h"
#include "apps/detector.h"
#include "detect/landmark_files.h"
#include "scan/capture.h"
#include "training/device.h"

namespace bareskin::cli {

void set_torch_threads(const Globals& globals) {
  // LibTorch defaults to the physical cores (1 on a 2-vCPU machine); follow --threads like the thread pool does.
  torch::set_num_threads(globals.threads > 0 ? globals.threads : int(std::thread::hardware_concurrency()));
}

ScanLandmarkDetector scan_landmark_detector(const Globals& globals, const std::string& calibration) {
  set_torch_threads(globals);
  return detect::face_api_scan_detector(calibration);
}

detect::PhotoDetector photo_detector(const Globals& globals, int input_size) {
  set_torch_threads(globals);
  return detect::face_api_photo_detector(input_size);
}

std::function<void()> setup_landmarks_command(CLI::App& app, const Globals& globals) {
  auto opt = std::make_shared<detect::PhotoLandmarksOptions>();
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
  add_device_option(*d, opt->device_name);

  auto sc = std::make_shared<detect::ScanLandmarkFilesOptions>();
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

  auto ca = std::make_shared<detect::CalibrationFilesOptions>();
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
      write_synthetic_capture(cp->scan, cp->texture, cp->output, cp->capture);
      return;
    }
    if (c->parsed()) return detect::write_calibration(*ca);
    if (s->parsed()) {
      sc->colmap.threads = globals.threads;
      detect::scan_landmark_files(*sc);
      return;
    }
    opt->device = parse_device(opt->device_name);
    detect::detect_photo_landmarks(*opt);
  };
}

}  // namespace bareskin::cli
