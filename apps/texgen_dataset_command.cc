// bareskin texgen make-dataset: the texture-inference training data (texgen/make_dataset.h; docs/datasets.md) from
// registered subjects and the morphable model, with face-api's detector (apps/detector.h) finding the landmarks the
// fits start from.
#include <algorithm>
#include <cstdlib>
#include <memory>

#include "apps/cli.h"
#include "apps/detector.h"  // set_torch_threads
#include "core/error.h"
#include "core/parallel.h"
#include "scan/multiview.h"
#include "texgen/make_dataset.h"
#include "detect/image_landmark_options.h"
#ifdef BARESKIN_WITH_DETECT
#include "detect/scan_landmarks.h"
#endif

namespace bareskin::cli {

namespace {

// The make-dataset detectors (face-api: detect/scan_landmarks.h) for renders and photos.
std::pair<texgen::FaceLandmarkDetector, texgen::FaceLandmarkDetector> detectors(const detect::ImageLandmarkOptions& o) {
#ifdef BARESKIN_WITH_DETECT
  const detect::ImageLandmarkFinders f = detect::face_api_finders(o);
  return {f.render, f.photo};
#else
  throw InvalidInput("texgen make-dataset", "needs face-api's detector, which this build lacks (no Torch side)",
                     "build bareskin with LibTorch");
#endif
}

}  // namespace

std::function<void()> setup_texgen_make_dataset(CLI::App& texgen, const Globals& globals) {
  struct Options {
    texgen::TextureDatasetOptions o;
    double yaw_left = 0, yaw_right = 0;  // the flags' text forms of o's defaults, filled below
    std::string occluders;
    std::vector<double> split;
    detect::ImageLandmarkOptions detector;
    bool no_flip = false, no_align_shape = false;
    std::string calibration, view_calibration;
  };
  auto opt = std::make_shared<Options>();
  texgen::TextureDatasetOptions& o = opt->o;
  for (const texgen::ViewSpec& v : o.sample.views) {
    if (v.name == "left") opt->yaw_left = v.yaw_deg;
    if (v.name == "right") opt->yaw_right = -v.yaw_deg;
  }
  for (const Occluder k : o.occluders) opt->occluders += (opt->occluders.empty() ? "" : ",") + std::string(to_string(k));
  opt->split.assign(o.split.begin(), o.split.end());
  CLI::App* app = texgen.add_subcommand("make-dataset", "Texture-inference samples in the template UV: three renders "
                                                        "per subject, 3DMM fits, merged unwrap, 3DMM maps, baked "
                                                        "targets, occlusion masks, as shards");
  app->add_option("registered", o.registered, "Registered subjects (scan register's output, the model's template)")
      ->required();
  app->add_option("--model", o.model, "The morphable model (mm-build's model.safetensors)")->required();
  app->add_option("-o,--output", o.output, "Dataset folder: train/, val/, test/, masks/ with shards and manifest.json")
      ->required();
  app->add_option("--yaw-left", opt->yaw_left, "Head turn of the left view (degrees; its left side toward the camera)")
      ->capture_default_str()->check(CLI::Range(0.0, 80.0))->group("Views");
  app->add_option("--yaw-right", opt->yaw_right, "Head turn of the right view (degrees)")->capture_default_str()
      ->check(CLI::Range(0.0, 80.0))->group("Views");
  app->add_option("--lights", o.lights, "Samples per subject: the light of the render the fits see; 1: the default "
                                        "light, each further one a random SH light")
      ->capture_default_str()->group("Views");
  app->add_option("--render-size", o.sample.render_size, "Render size of each view (a multiple of --fit-size)")
      ->capture_default_str()->group("Views");
  app->add_option("--detector-size", opt->detector.input_size, "Face detector input (multiple of 32)")->capture_default_str()
      ->group("Fit");
  app->add_option("--refinements", opt->detector.refinements, "Landmark passes on the box the previous points imply")
      ->capture_default_str()->check(CLI::Range(0, 10))->group("Fit");
  app->add_flag("--no-flip", opt->no_flip, "Landmarks from the image alone (default: averaged with those of its mirror "
                                          "image)")->group("Fit");
  app->add_option("--fitter", o.fitter, "mm-fit (detected landmarks, then the photometric fit); recon (the network F) "
                                        "once it exists")
      ->capture_default_str()->check(CLI::IsMember({"mm-fit", "recon"}))->group("Fit");
  app->add_option("--landmark-fit", o.sample.landmark_fit_mode, "shared-shape (one shape for the views, a pose per "
                                                                 "view), rigid (one shape and head pose, the views' "
                                                                 "known rotations) or per-view (independent fits)")
      ->capture_default_str()->check(CLI::IsMember({"shared-shape", "rigid", "per-view"}))->group("Fit");
  app->add_option("--landmark-calibration", opt->calibration, "The detector's landmark convention (`landmarks "
                                                              "calibrate`), applied to the model's landmarks in the fits")
      ->check(CLI::ExistingFile)->group("Fit");
  app->add_option("--view-calibration", opt->view_calibration, "The detector's per-view landmark bias (made by "
                                                              "--write-view-calibration on training subjects with the "
                                                              "same --landmark-calibration and yaws), subtracted from "
                                                              "each view's detected landmarks")
      ->check(CLI::ExistingFile)->group("Fit");
  app->add_option("--write-view-calibration", o.write_view_calibration, "After a complete run: learn the detector's "
                                                                        "per-view landmark bias from this run's reports "
                                                                        "(detected vs true landmarks) into this file")
      ->group("Fit");
  app->add_option("--robust-landmarks", o.sample.landmark_robust_rounds, "Reweighted refits of the landmark fit: "
                                                                        "landmarks far from the fitted shape lose weight "
                                                                        "(Cauchy weights on the reprojection error)")
      ->capture_default_str()->group("Fit");
  app->add_option("--silhouette-rounds", o.sample.silhouette.rounds, "Rounds of the silhouette term: each view's "
                                                                      "fitted outline onto the render's (0: off)")
      ->capture_default_str()->group("Fit");
  app->add_option("--silhouette-weight", o.sample.silhouette.weight, "A view's outline points together weigh this "
                                                                      "times its 68 landmarks")
      ->capture_default_str()->group("Fit");
  app->add_option("--align-views", o.sample.align.rounds, "Passes of photometric consistency: the shared shape and "
                                                          "the side views' poses moved so that the views' unwraps "
                                                          "agree (0: off)")
      ->capture_default_str()->check(CLI::Range(0, 10))->group("Fit");
  app->add_flag("--no-align-shape", opt->no_align_shape, "The view alignment moves the side views' poses only (the "
                                                         "shape stays the landmark fit's)")->group("Fit");
  app->add_option("--align-landmark-weight", o.sample.align.landmark_weight, "Weight of the views' landmarks against "
                                                                          "the colours in the view alignment (0: colours alone)")
      ->capture_default_str()->group("Fit");
  app->add_option("--align-shape-prior", o.sample.align.shape_prior, "Weight of the shape prior in the view alignment "
                                                                     "(per mean α² in standard deviations)")
      ->capture_default_str()->group("Fit");
  app->add_option("--align-size", o.sample.align.size, "UV and image size of the view alignment's finest level")
      ->capture_default_str()->group("Fit");
  app->add_option("--landmark-regularisation", o.sample.landmark_fit.regularisation, "Weight of the shape prior in the "
                                                                                     "landmark fit (px² per std²)")
      ->capture_default_str()->check(CLI::Range(0.0, 1e6))->group("Fit");
  app->add_option("--fit-size", o.sample.fit_size, "Image size of the photometric fit")->capture_default_str()->group("Fit");
  app->add_option("--shape-components", o.sample.landmark_fit.shape_components, "Identity components fitted")
      ->capture_default_str()->group("Fit");
  app->add_option("--appearance-components", o.sample.photometric.appearance_components, "Appearance components fitted")
      ->capture_default_str()->group("Fit");
  app->add_option("--input-res", o.sample.input_res, "UV size of the inputs (unwrap, confidence, 3DMM maps, masks)")
      ->capture_default_str()->group("Sizes");
  app->add_option("--target-res", o.target_res, "UV size of the targets (divides the registered maps' size)")
      ->capture_default_str()->group("Sizes");
  app->add_option("--hr-res", o.hr_res, "UV size of the high-res targets (*_hr.png; 0: none)")->capture_default_str()
      ->group("Sizes");
  app->add_option("--merge-sharpness", o.sample.merge_sharpness, "Views are weighted by confidence^this")
      ->capture_default_str()->group("Sizes");
  app->add_option("--masks", o.masks_per_subject, "Synthetic occluder masks per subject")->capture_default_str()
      ->group("Masks");
  app->add_option("--occluders", opt->occluders, "Synthetic occluders to draw from")->capture_default_str()->group("Masks");
  app->add_option("--celebamask", o.celebamask, "CelebAMask-HQ folder (CelebA-HQ-img/, CelebAMask-HQ-mask-anno/): "
                                                "its skin labels as UV masks")
      ->group("Masks");
  app->add_option("--celebamask-count", o.celebamask_count, "CelebAMask photos used (lowest ids first)")
      ->capture_default_str()->group("Masks");
  app->add_option("--split", opt->split, "Train, val, test fractions of the subjects")->delimiter(',')->expected(3)
      ->capture_default_str()->group("Shards");
  app->add_option("--subjects-per-shard", o.subjects_per_shard, "Subjects per shard (the unit of resume and of work "
                                                                "sharing)")
      ->capture_default_str()->group("Shards");
  CLI::Option* shard = app->add_option("--shard", o.shard, "This worker (default: SLURM_ARRAY_TASK_ID)")->group("Shards");
  CLI::Option* shards = app->add_option("--shards", o.shards, "Workers sharing the run (default: SLURM_ARRAY_TASK_COUNT)")
                            ->group("Shards");
  app->add_option("--seed", o.seed, "Random seed: the same seed gives the same bytes")->capture_default_str()
      ->group("Shards");
  app->add_flag("--keep-going", o.keep_going, "Skip subjects or photos with bad input and list them at the end");
  app->add_flag("--unwrap-lit", o.sample.unwrap_lit, "Unwrap the lit render instead of the diffuse-only one");
  app->add_option("--drop-background", o.sample.drop_background, "1: texels whose sample touches the render's background "
                                                                  "(a fitted outline wider than the face) count as unseen; 0: keep them")
      ->capture_default_str();
  app->add_flag("--with-renders", o.with_renders, "Also store each view's renders (render_<view>.png lit, bare_<view>.png diffuse only)");

  return [opt, app, shard, shards, &globals] {
    if (!app->parsed()) return;
    keep_freed_memory();  // before the bake and encode threads start: one heap, no fresh pages per subject
    texgen::TextureDatasetOptions& o = opt->o;
    o.sample.views = {{"front", 0}, {"left", opt->yaw_left}, {"right", -opt->yaw_right}};
    o.occluders = parse_occluders(opt->occluders);
    o.split = {opt->split[0], opt->split[1], opt->split[2]};
    const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
    if (shard->count() == 0 && id && *id) {
      const char* min = std::getenv("SLURM_ARRAY_TASK_MIN");
      const char* count = std::getenv("SLURM_ARRAY_TASK_COUNT");
      o.shard = std::atoi(id) - (min && *min ? std::atoi(min) : 0);
      if (shards->count() == 0 && count && *count) o.shards = std::atoi(count);
    }
    if (!opt->calibration.empty()) {
      const LandmarkCalibration c = read_landmark_calibration(opt->calibration);
      o.landmark_calibration = texgen::TextureDatasetOptions::LandmarkCalibration{opt->calibration, c.reference, c.offset};
    }
    if (!opt->view_calibration.empty()) {
      o.sample.view_calibration = texgen::read_view_calibration(opt->view_calibration);
      o.sample.view_calibration_source = opt->view_calibration;
    }
    if (opt->no_align_shape) o.sample.align.shape = false;
    o.check();
    opt->detector.flip = !opt->no_flip;
    const auto [render_detect, photo_detect] = detectors(opt->detector);
    ProgressBar bar = globals.progress("make-dataset");
    const texgen::TextureDatasetReport r =
        texgen::make_texture_dataset(o, render_detect, photo_detect, bar.callback());
    bar.finish();
    globals.write_resolved_config(o.output + "/config.json");
    spdlog::info("make-dataset: {} subjects (train {}, val {}, test {}); worker {}/{}: {} of {} units done now, {} "
                 "already done; {} samples and {} masks written in {:.1f} s -> {}",
                 r.subjects, r.split_subjects[0], r.split_subjects[1], r.split_subjects[2], o.shard, o.shards,
                 r.units_done, r.units_mine, r.units_resumed, r.samples, r.masks, r.seconds, o.output);
    for (const auto& s : r.skipped) spdlog::warn("make-dataset: skipped {}: {}", s.item, s.reason);
    if (!r.skipped.empty()) spdlog::warn("make-dataset: {} item(s) skipped (listed above and in the manifests)", r.skipped.size());
    if (!r.complete) spdlog::info("make-dataset: other workers' units are still missing; the last worker to finish "
                                  "writes the final manifests{}",
                                  o.write_view_calibration.empty() ? "" : " and the view calibration");
    else if (!o.write_view_calibration.empty())
      spdlog::info("make-dataset: view calibration -> {}", o.write_view_calibration);
  };
}

}  // namespace bareskin::cli
