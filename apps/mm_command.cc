// bareskin mm-build / mm-eval: the morphable model from registered scans (registering what is not yet registered),
// and its metrics (compactness, generalisation, specificity; per region).
#include <chrono>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "apps/detector.h"
#include "apps/model_input.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "morphable/build.h"
#include "morphable/coefficients.h"
#include "morphable/export.h"
#include "core/landmarks.h"
#include "morphable/fit.h"
#include "morphable/metrics.h"
#include "scan/blendshapes.h"
#include "scan/register_folder.h"

namespace bareskin::cli {
namespace {

namespace fs = std::filesystem;

// Registered subject folders under `dir`: the ones holding a mesh.
std::vector<std::string> registered_subjects(const std::string& dir) {
  if (!fs::is_directory(dir)) throw IoError(dir, "is not a folder", "give registered scans, or scans to register");
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.is_directory() && (fs::exists(e.path() / "mesh.ply") || fs::exists(e.path() / "mesh.obj"))) {
      out.push_back(e.path().string());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::string stem_path(const std::string& model_path) {
  const fs::path p(model_path);
  return (p.parent_path() / p.stem()).string();
}

}  // namespace

std::function<void()> setup_mm_build_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string scans, registered, output = "model.safetensors", template_dir, blendshapes, export_obj;
    int maps_res = 1024;
    BuildOptions build;
  };
  auto opt = std::make_shared<Options>();
  app.add_option("scans", opt->scans,
                 "Scans to register first (scan folders; already registered ones are reused). Omit to build from "
                 "--registered alone");
  app.add_option("-o,--output", opt->output, "Model file (safetensors)")->capture_default_str();
  app.add_option("--registered", opt->registered, "Registered subjects (cache of 'scan register'); default: "
                                                  "'registered' beside the model");
  app.add_option("--template", opt->template_dir, "Template folder from 'bareskin template' (default: BARESKIN_TEMPLATE, "
                                                  "then the installed one; docs/cli.md)");
  app.add_option("--maps-res", opt->maps_res, "Map resolution when registering scans")->capture_default_str();
  CLI::Option* shape_k = app.add_option("--shape-components", opt->build.shape_components,
                                        "Identity components (alpha); the default is clamped to subjects - 1, a given count is not")
                             ->capture_default_str()->group("Model");
  app.add_option("--shape-variance", opt->build.shape_variance,
                 "Keep only as many identity components as explain this variance fraction (0: off)")
      ->capture_default_str()->group("Model");
  CLI::Option* app_k = app.add_option("--appearance-components", opt->build.appearance_components,
                                      "Appearance components (delta; 0: no appearance model)")
                           ->capture_default_str()->group("Model");
  app.add_option("--appearance-res", opt->build.appearance_resolution, "Appearance map size in the model (R x R)")
      ->capture_default_str()->group("Model");
  CLI::Option* exp_k = app.add_option("--expression-components", opt->build.expression_components,
                                      "Expression components (beta); at most the blendshape count")
                           ->capture_default_str()->group("Model");
  app.add_option("--blendshapes", opt->blendshapes,
                 "Blendshape set (safetensors 'deltas' [K,V,3]); default: the set made on the template")
      ->group("Model");
  app.add_flag("--procrustes-scale", opt->build.procrustes_scale, "Align subjects with scale (similarity GPA)")
      ->group("Model");
  app.add_option("--export-obj", opt->export_obj, "Also write OBJs of the mean and of +-3 sd, and appearance PNGs, here");
  return [opt, shape_k, app_k, exp_k, &globals] {
    const auto t0 = std::chrono::steady_clock::now();
    opt->build.check();
    opt->build.exact.shape = shape_k->count() > 0;
    opt->build.exact.appearance = app_k->count() > 0;
    opt->build.exact.expression = exp_k->count() > 0;
    const fs::path out_dir = fs::path(opt->output).parent_path();
    if (opt->registered.empty()) opt->registered = (out_dir / "registered").string();
    opt->template_dir = find_template_folder(opt->template_dir);
    const TemplateFace face = read_template_folder(opt->template_dir);

    std::vector<std::string> subjects;
    double register_seconds = 0;
    if (!opt->scans.empty()) {
      RegisterFolderOptions reg;
      reg.scans = opt->scans;
      reg.output = opt->registered;
      reg.maps.resolution = opt->maps_res;
      if (opt->maps_res > 0) reg.maps.check();
      if (opt->build.appearance_components > 0 && opt->maps_res == 0) {
        throw InvalidInput("", "--maps-res 0 leaves no diffuse maps for the appearance model",
                           "give --maps-res 1024, or --appearance-components 0");
      }
      reg.detect = scan_landmark_detector(globals);
      ProgressBar register_bar = globals.progress("scan register");
      subjects = register_folder(face, reg, register_bar.callback());
      register_bar.finish();
      globals.write_resolved_config(reg.output + "/config.json");
      register_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    } else {
      subjects = registered_subjects(opt->registered);
    }
    std::vector<NamedShape> blendshapes;
    for (const Blendshape& b : opt->blendshapes.empty() ? make_blendshapes(face) : read_blendshapes(opt->blendshapes)) {
      blendshapes.push_back({b.name, b.delta});
    }

    ProgressBar bar = globals.progress("mm-build");
    BuildReport report;
    MorphableModel model = build_model(face, subjects, blendshapes, opt->build, report, bar.callback());
    bar.finish();
    model.metadata["provenance"] = fmt::format("bareskin mm-build {}: {} subjects from {}, template {}", BARESKIN_VERSION,
                                               subjects.size(), opt->registered, opt->template_dir);
    model.metadata["config"] = nlohmann::json{{"procrustes_scale", opt->build.procrustes_scale},
                                              {"shape_variance", opt->build.shape_variance},
                                              {"appearance_resolution", opt->build.appearance_resolution},
                                              {"blendshapes", opt->blendshapes.empty() ? "template set" : opt->blendshapes}}
                                   .dump();
    const auto t_write = std::chrono::steady_clock::now();
    if (!out_dir.empty()) make_directories(out_dir.string());
    write_model(opt->output, model);
    const double write_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_write).count();
    if (!opt->export_obj.empty()) export_model_previews(opt->export_obj, model);

    nlohmann::json summary = {
        {"model", opt->output},
        {"subjects", report.subjects},
        {"components", {{"shape", model.shape_basis.rows()}, {"expression", model.expression_basis.rows()},
                        {"appearance", model.appearance_basis.rows()}}},
        {"variance_explained", {{"shape", report.shape_variance_explained},
                                {"appearance", report.appearance_variance_explained}}},
        {"gpa_iterations", report.gpa_iterations},
        {"appearance_subjects", report.appearance_subjects},
        {"subjects_without_diffuse", report.subjects_without_diffuse},
        {"notes", report.notes},
        {"seconds", {{"register", register_seconds},
                     {"read_shapes", report.seconds_read_shapes},
                     {"gpa", report.seconds_gpa},
                     {"shape_pca", report.seconds_shape_pca},
                     {"read_maps", report.seconds_read_maps},
                     {"appearance_pca", report.seconds_appearance_pca},
                     {"expression", report.seconds_expression},
                     {"write", write_seconds},
                     {"total", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()}}}};
    write_file_atomic(stem_path(opt->output) + ".build.json", summary.dump(1) + "\n");
    globals.write_resolved_config(stem_path(opt->output) + ".config.json");
    spdlog::info("mm-build: {} subjects -> {} ({} identity, {} expression, {} appearance components; {:.1f}% / {:.1f}% "
                 "of shape / appearance variance); {:.1f} s (read {:.1f}, GPA {:.1f}, PCA {:.1f}, maps {:.1f}, "
                 "appearance PCA {:.1f})",
                 report.subjects, opt->output, model.shape_basis.rows(), model.expression_basis.rows(),
                 model.appearance_basis.rows(), 100 * report.shape_variance_explained,
                 100 * report.appearance_variance_explained, summary["seconds"]["total"].get<double>(),
                 report.seconds_read_shapes, report.seconds_gpa, report.seconds_shape_pca, report.seconds_read_maps,
                 report.seconds_appearance_pca);
  };
}

std::function<void()> setup_mm_eval_command(CLI::App& app, const Globals& globals) {
  auto opt = std::make_shared<EvaluateModelOptions>();
  app.add_option("model", opt->model, "Model from 'bareskin mm-build'")->required();
  app.add_option("registered", opt->registered, "Registered subjects (the model's training set)")->required();
  app.add_option("-o,--output", opt->output, "Output folder (metrics.csv, metrics.json, *.svg); default: "
                                             "<model>_metrics beside the model");
  app.add_option("--samples", opt->metrics.samples, "Random model shapes for specificity")->capture_default_str();
  app.add_option("--max-components", opt->metrics.max_components, "Largest component count evaluated")->capture_default_str();
  app.add_option("--max-held-out", opt->metrics.max_held_out, "Subjects left out in turn for generalisation (at most)")
      ->capture_default_str();
  app.add_option("--seed", opt->metrics.seed, "Sampling seed")->capture_default_str();
  return [opt, &globals] {
    opt->config = globals.resolved_config();
    evaluate_model(*opt);
  };
}

std::function<void()> setup_mm_fit_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string image, model, landmarks, output = "fit.json", view = "front", trace, skin_mask;
    LandmarkFitOptions fit;
    PhotometricFitOptions photo;
    bool no_photometric = false;
  };
  auto opt = std::make_shared<Options>();
  app.add_option("image", opt->image, "The (square) image the landmarks belong to")->required();
  app.add_option("--model", opt->model, "Model from 'bareskin mm-build'")->required();
  app.add_option("--landmarks", opt->landmarks, "68 iBUG landmarks in the image (JSON or .pts, pixels)")->required();
  app.add_option("-o,--output", opt->output,
                 "Coefficients (JSON: alpha, beta, delta, gamma, rotation, translation; read by render, uvtools)")
      ->capture_default_str();
  app.add_option("--view", opt->view, "Camera as 'render --model': front, left or right")->capture_default_str()
      ->check(CLI::IsMember({"front", "left", "right"}));
  app.add_option("--shape-components", opt->fit.shape_components, "Identity components fitted")->capture_default_str();
  app.add_option("--expression-components", opt->fit.expression_components, "Expression components fitted")
      ->capture_default_str();
  app.add_option("--regularisation", opt->fit.regularisation, "Weight of |alpha|^2 (px^2 per unit)")->capture_default_str();
  app.add_option("--iterations", opt->fit.iterations, "Levenberg-Marquardt iterations (at most)")->capture_default_str();
  app.add_option("--appearance-components", opt->photo.appearance_components, "Appearance components fitted (delta)")
      ->capture_default_str()->group("Photometric");
  app.add_option("--colour-noise", opt->photo.noise, "Per-pixel colour noise (linear), weighing data against the priors")
      ->capture_default_str()->check(CLI::Range(1e-6, 10.0))->group("Photometric");
  app.add_option("--lighting-sd", opt->photo.lighting_sd, "Prior spread of the SH coefficients around white ambient")
      ->capture_default_str()->check(CLI::Range(1e-6, 100.0))->group("Photometric");
  app.add_option("--skin-mask", opt->skin_mask, "Image of the photo's size, white where the photometric term may look "
                 "(e.g. a face parser's skin class); default: every pixel the face covers")
      ->check(CLI::ExistingFile)->group("Photometric");
  app.add_flag("--no-photometric", opt->no_photometric, "Landmarks only: no delta or gamma")->group("Photometric");
  app.add_option("--trace", opt->trace,
                 "Accuracy per iteration and time: a CSV, and beside it <stem>_landmarks.svg and <stem>_photometric.svg");
  return [opt, &globals] {
    opt->fit.check();
    check_output_file(opt->output);
    check_output_apart(opt->output, {opt->image, opt->model, opt->landmarks, opt->skin_mask});
    if (!opt->trace.empty()) {
      check_output_file(opt->trace);
      check_output_apart(opt->trace, {opt->image, opt->model, opt->landmarks, opt->skin_mask, opt->output});
    }
    const ImageFileInfo info = probe_image(opt->image);
    if (info.width != info.height) throw InvalidInput(opt->image, "is not square", "give the square crop");
    const Landmarks lm = read_image_landmarks(opt->landmarks, info.width, info.height);
    const MorphableModel model = read_model(opt->model);
    const Camera camera = command_camera(model.topology, true, opt->view, "pinhole", info.width);
    const auto t0 = std::chrono::steady_clock::now();
    const LandmarkFit fit = fit_landmarks(model, lm.points, camera, opt->fit);
    PhotometricFit photo;
    if (!opt->no_photometric) {
      Image image = read_image(opt->image);
      if (image.color_space == ColorSpace::sRGB) image = to_linear(image);
      const Mesh posed = posed_mesh(model, to_coefficients(fit));
      Image skin;
      if (!opt->skin_mask.empty()) {
        skin = read_image(opt->skin_mask);
        if (skin.width != info.width || skin.height != info.height) {
          throw InvalidInput(opt->skin_mask, "is " + std::to_string(skin.width) + "x" + std::to_string(skin.height) +
                                                 ", the image " + std::to_string(info.width) + "x" + std::to_string(info.height),
                             "give a mask of the photo's size");
        }
        opt->photo.skin_mask = &skin;
      }
      photo = fit_photometric(model, posed, camera, image, opt->photo);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    Coefficients c = to_coefficients(fit);
    c.extra = {{"landmark_rms_px", fit.rms_px},
               {"iterations", fit.iterations},
               {"seconds", seconds},
               {"view", opt->view},
               {"image_size", info.width},
               {"terms", opt->no_photometric ? "landmarks + regularisation"
                                             : "landmarks + regularisation, then photometric (delta, gamma)"}};
    if (!opt->no_photometric) {
      c.delta = photo.delta;
      c.gamma = photo.gamma;
      c.extra["photometric_psnr_db"] = photo.psnr_db;
      c.extra["photometric_pixels"] = photo.pixels;
    }
    write_coefficients(opt->output, c);
    if (!opt->trace.empty()) write_fit_trace(opt->trace, fit, photo);
    spdlog::info("mm-fit: {} identity and {} expression components, landmark RMS {:.3f} px after {} iterations; "
                 "photometric PSNR {:.1f} dB over {} pixels ({:.2f} s) -> {}",
                 fit.alpha.size(), fit.beta.size(), fit.rms_px, fit.iterations, photo.psnr_db, photo.pixels, seconds,
                 opt->output);
  };
}

}  // namespace bareskin::cli
