// bareskin scan: `scan synth` (a synthetic population of scans with ground truth) here; `scan register` in scan_register.cc.
#include <atomic>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "apps/cli.h"
#include "core/error.h"
#include "core/files.h"
#include "core/parallel.h"
#include "scan/blendshapes.h"
#include "scan/synth.h"

namespace bareskin::cli {

CLI::App* add_scan_register(CLI::App& scan, const Globals& globals, std::function<void()>& action);

std::function<void()> setup_scan_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string template_dir = "template", output = "scans", map_format = "png";
    SynthOptions synth;
  };
  auto opt = std::make_shared<Options>();
  app.require_subcommand(1);
  CLI::App* synth = app.add_subcommand("synth", "Make a synthetic population of scans with ground truth");
  synth->add_option("-o,--output", opt->output, "Population folder (one folder per subject + manifest.json)")
      ->capture_default_str();
  synth->add_option("--template", opt->template_dir, "Template folder from 'bareskin template'")->capture_default_str();
  synth->add_option("--count", opt->synth.count, "Subjects")->capture_default_str();
  synth->add_option("--seed", opt->synth.seed, "Population seed (same seed: identical files)")->capture_default_str();
  synth->add_option("--vertices", opt->synth.scan_vertices, "Vertices per scan (about; 2 triangles each)")
      ->capture_default_str()->group("Scan mesh");
  synth->add_option("--remesh-iterations", opt->synth.remesh_iterations, "Isotropic remeshing passes per scan")
      ->capture_default_str()->group("Scan mesh");
  synth->add_option("--noise", opt->synth.noise_mm, "Measurement noise along normals, sigma in mm")
      ->capture_default_str()->group("Realism");
  synth->add_option("--scale-jitter", opt->synth.scale_jitter, "Random scale in [1-s, 1+s]")
      ->capture_default_str()->group("Realism");
  synth->add_option("--rotation-jitter", opt->synth.rotation_jitter_deg, "Random rotation up to this many degrees")
      ->capture_default_str()->group("Realism");
  synth->add_option("--translation-jitter", opt->synth.translation_jitter_mm, "Random shift up to this many mm per axis")
      ->capture_default_str()->group("Realism");
  synth->add_flag("--holes", opt->synth.holes, "Cut the nostrils open, as scanners leave them")->group("Realism");
  synth->add_option("--res", opt->synth.maps.resolution, "Map resolution in the scan's atlas (0: no maps; 16384 works)")
      ->capture_default_str()->group("Maps");
  synth->add_option("--map-format", opt->map_format, "png (16-bit, sRGB diffuse), tif (16-bit) or exr (half, linear)")
      ->capture_default_str()->group("Maps");
  synth->add_option("--gutter", opt->synth.maps.gutter, "Texels filled beyond each chart's edge")
      ->capture_default_str()->group("Maps");
  synth->add_option("--truth-res", opt->synth.truth_resolution,
                    "Also bake the true maps in the template UV at this resolution into truth/maps/ (0: no)")
      ->capture_default_str()->group("Maps");
  synth->add_option("--feature-scale", opt->synth.identity.feature_scale, "Strength of the semantic feature controls")
      ->capture_default_str()->group("Identity");
  synth->add_option("--tangential", opt->synth.identity.tangential,
                    "Share of the identity displacement along the surface that is kept [0,1]")
      ->capture_default_str()->group("Identity");
  synth->add_option("--symmetry", opt->synth.identity.symmetry, "Mirror-symmetric share of the random field [0,1]")
      ->capture_default_str()->group("Identity");
  auto register_action = std::make_shared<std::function<void()>>();
  add_scan_register(app, globals, *register_action);
  return [opt, &globals, synth, register_action] {
    if (!synth->parsed()) return (*register_action)();
    opt->synth.maps.format = parse_map_format(opt->map_format);
    opt->synth.check();
    const TemplateFace face =
        read_template(opt->template_dir + "/face.obj", opt->template_dir + "/landmarks.json");
    make_directories(opt->output);
    // Resumable: a subject folder appears only when complete (atomic), so existing ones are skipped.
    std::vector<int> todo;
    for (int i = 0; i < opt->synth.count; ++i) {
      char id[32];
      std::snprintf(id, sizeof id, "subject_%04d", i);
      if (!std::filesystem::exists(opt->output + "/" + id + "/truth/identity.json")) todo.push_back(i);
    }
    if (todo.size() < size_t(opt->synth.count)) {
      spdlog::info("scan synth: {} of {} subjects already there, skipped", opt->synth.count - int(todo.size()), opt->synth.count);
    }
    ProgressBar bar = globals.progress("scan synth");
    std::atomic<int> done{0};
    // Several subjects: one per thread. A single subject: its maps are baked in parallel, and the bar follows them.
    const bool one = todo.size() == 1;
    const ProgressCallback maps_progress = [&](int64_t d, int64_t total, const std::string&) {
      if (one) bar.update(d, total, "map bands");
    };
    const auto make = [&](int64_t k) {
      write_scan(opt->output, face, synthesize_scan(face, todo[size_t(k)], opt->synth), opt->synth, maps_progress);
      if (!one) bar.update(++done, int64_t(todo.size()), "subjects");
    };
    if (one) {
      make(0);  // on this thread, so that the bake's own parallel_for is not nested (nested loops run serially)
    } else {
      parallel_for(0, int64_t(todo.size()), [&](int64_t b, int64_t e) {
        for (int64_t k = b; k < e; ++k) make(k);
      });
    }
    bar.finish();
    const std::vector<Blendshape> shapes = make_blendshapes(face);
    write_blendshapes(opt->output + "/blendshapes", shapes);
    nlohmann::json manifest;
    manifest["format"] = "bareskin.scan_population";
    manifest["format_version"] = 1;
    manifest["seed"] = opt->synth.seed;
    manifest["count"] = opt->synth.count;
    manifest["template"] = std::filesystem::absolute(opt->template_dir).string();
    manifest["identity_features"] = identity_feature_names();
    manifest["blendshapes"] = int(shapes.size());
    manifest["contents"] = "per subject mesh.obj (own topology and UV atlas), diffuse/normal/roughness/specular maps, "
                           "landmarks.json, truth/; blendshapes/ on the template";
    manifest["maps"] = {{"resolution", opt->synth.maps.resolution}, {"format", opt->map_format}};
    write_file_atomic(opt->output + "/manifest.json", manifest.dump(1) + "\n");
    globals.write_resolved_config(opt->output + "/config.json");
    spdlog::info("scan synth: {} subjects in {}", opt->synth.count, opt->output);
  };
}

}  // namespace bareskin::cli
