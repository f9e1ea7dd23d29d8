// bareskin texgen faces: the face-image world with makeup, light and full truth as dataset shards
// (texgen/faces.h; docs/datasets.md).

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "texgen/faces.h"

namespace bareskin::cli {
namespace {

// SLURM job arrays: the task id picks this worker's shards when --shard is not given.
void apply_slurm(texgen::FacesOptions& o, bool shard_given, bool shards_given) {
  const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
  if (shard_given || !id || !*id) return;
  const char* min = std::getenv("SLURM_ARRAY_TASK_MIN");
  const char* count = std::getenv("SLURM_ARRAY_TASK_COUNT");
  o.shard = std::atoi(id) - (min && *min ? std::atoi(min) : 0);
  if (!shards_given && count && *count) o.shards = std::atoi(count);
}

}  // namespace

std::function<void()> setup_texgen_faces(CLI::App& texgen, const Globals& globals) {
  auto opt = std::make_shared<texgen::FacesOptions>();
  CLI::App* app = texgen.add_subcommand("faces", "Face images with makeup, light and full truth (coefficients, bare "
                                                 "albedo, masks, landmarks) as dataset shards");
  app->add_option("--registered", opt->registered, "Registered subjects (scan register's output): their geometry and "
                                                   "maps");
  app->add_option("--model", opt->model, "The morphable model (mm-build's model.safetensors)")->required();
  app->add_option("-o,--output", opt->output, "Dataset folder: train/, val/, test/ with shards and manifest.json")
      ->required();
  app->add_option("--count", opt->count, "Samples over all splits")->capture_default_str();
  app->add_option("--seed", opt->seed, "Random seed: the same seed gives the same bytes")->capture_default_str();
  app->add_option("--mm-subjects", opt->mm_subjects, "3DMM identities (α, δ ~ N(0, 1)) beside the registered ones")
      ->capture_default_str();
  app->add_option("--skin-tones", opt->skin_tones,
                  "The 3DMM identities' skin tones: model (as the model's population), balanced (the six ITA "
                  "groups, very light to dark, in turn) or mixed (every other identity each way)")
      ->capture_default_str();
  app->add_option("--val", opt->val, "Validation subjects: a count, or a fraction when < 1")->capture_default_str();
  app->add_option("--test", opt->test, "Test subjects: a count, or a fraction when < 1")->capture_default_str();
  app->add_option("--styles", opt->styles, "Makeup styles to draw from (none,light,natural,heavy,dramatic or all)")
      ->capture_default_str();
  app->add_option("--exclude-styles", opt->exclude_styles, "Styles kept out of train and val (they go to test only)");
  app->add_option("--align", opt->align, "How the 5-point alignment finds the landmarks: detector (as real photos) "
                                         "or truth (the projected landmark vertices)")
      ->capture_default_str()->check(CLI::IsMember({"detector", "truth"}));
  app->add_option("--yaw-max", opt->ranges.yaw_max, "Head yaw range ±, degrees")->capture_default_str();
  app->add_option("--pitch-max", opt->ranges.pitch_max, "Head pitch range ±, degrees")->capture_default_str();
  app->add_option("--roll-max", opt->ranges.roll_max, "Head roll range ±, degrees")->capture_default_str();
  app->add_option("--expression-max", opt->ranges.expression_max, "Expression |β| bound, standard deviations")
      ->capture_default_str();
  app->add_option("--expression-prob", opt->ranges.expression_prob, "Share of samples with an expression")
      ->capture_default_str()->check(CLI::Range(0.0, 1.0));
  app->add_option("--light-max", opt->ranges.light_max, "Strength of the directional SH lobe over the ambient")
      ->capture_default_str();
  app->add_option("--specular-max", opt->ranges.specular_max, "Intensity of the specular key light")
      ->capture_default_str()->check(CLI::Range(0.0, 5.0));
  app->add_option("--occluders", opt->occluder_prob, "Share of samples with occluders (hair, glasses, hand, hat)")
      ->capture_default_str();
  app->add_option("--shard-size", opt->shard_size, "Samples per shard")->capture_default_str();
  CLI::Option* shard = app->add_option("--shard", opt->shard, "This worker's number (default: SLURM_ARRAY_TASK_ID)");
  CLI::Option* shards = app->add_option("--shards", opt->shards, "Workers sharing the run (default: "
                                                                  "SLURM_ARRAY_TASK_COUNT)");
  app->add_option("--map-size", opt->map_size, "Registered maps are resampled to this size; makeup is painted at it")
      ->capture_default_str();
  app->add_option("--layer-size", opt->layer_size, "Size of the stored makeup layer (layer.png, finish.png); divides "
                                                   "--map-size")
      ->capture_default_str();
  app->add_option("--backgrounds", opt->backgrounds, "Folder of background photos (default: scikit-image's sample photos, "
                                                   "Debian's python3-skimage; missing or \"\": procedural only)")
      ->capture_default_str();
  app->footer("Example:\n  bareskin texgen faces --registered out/registered --model out/model/model.safetensors "
              "--count 1000 --seed 1 -o out/faces\ndocs/datasets.md describes the world and the sample format.");
  return [opt, app, shard, shards, &globals] {
    if (!app->parsed()) return;
    apply_slurm(*opt, shard->count() > 0, shards->count() > 0);
    opt->generator = std::string("bareskin texgen faces ") + BARESKIN_VERSION;
    opt->check();
    detect::PhotoDetector detector;
    if (opt->align == "detector") {
      detector = photo_detector(globals);
      if (!detector)
        throw InvalidInput("--align detector", "this build has no face detector (no LibTorch)", "use --align truth");
    }
    ProgressBar bar = globals.progress("texgen faces");
    const texgen::FacesReport report = texgen::write_faces(*opt, detector, bar.callback());
    bar.finish();
    const std::string suffix = opt->shards > 1 ? "-" + std::to_string(opt->shard) : "";
    globals.write_resolved_config(opt->output + "/config" + suffix + ".json");
    spdlog::info("texgen faces: {} samples in {} shards ({} kept from an earlier run) in {:.1f} s ({:.1f}/s){}",
                 report.samples_written, report.shards_written, report.shards_skipped, report.seconds,
                 report.seconds > 0 ? report.samples_written / report.seconds : 0.0,
                 report.detector_runs ? fmt::format("; detector found {} of {} faces", report.detected,
                                                    report.detector_runs)
                                      : "");
  };
}

}  // namespace bareskin::cli
