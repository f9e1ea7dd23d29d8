// bareskin mm-build / mm-eval: the morphable model from registered scans (registering what is not yet registered),
// and its metrics (compactness, generalisation, specificity; per region).
#include <memory>
#include <string>

#include "apps/detector.h"
#include "core/progress.h"
#include "morphable/fit.h"
#include "morphable/metrics.h"
#include "scan/model_files.h"

namespace bareskin::cli {

std::function<void()> setup_mm_build_command(CLI::App& app, const Globals& globals) {
  auto opt = std::make_shared<ModelFilesOptions>();
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
    opt->build.exact.shape = shape_k->count() > 0;
    opt->build.exact.appearance = app_k->count() > 0;
    opt->build.exact.expression = exp_k->count() > 0;
    opt->generator = std::string("bareskin mm-build ") + BARESKIN_VERSION;
    ModelFilesHooks hooks;
    hooks.progress = [&globals](const std::string& stage) {
      auto bar = std::make_shared<ProgressBar>(stage, !globals.quiet());  // finished when the stage drops it
      return ProgressCallback([bar](int64_t done, int64_t total, const std::string& s) { bar->update(done, total, s); });
    };
    if (!opt->scans.empty()) hooks.detect = scan_landmark_detector(globals);
    hooks.registered = [&globals](const std::string& folder) { globals.write_resolved_config(folder + "/config.json"); };
    const std::string stem = build_model_files(*opt, hooks);
    globals.write_resolved_config(stem + ".config.json");
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

std::function<void()> setup_mm_fit_command(CLI::App& app, const Globals&) {
  auto opt = std::make_shared<FitFilesOptions>();
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
  return [opt] { fit_files(*opt); };
}

}  // namespace bareskin::cli
