// `bareskin mm-build` on files (model_files.h).
#include "scan/model_files.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "morphable/export.h"
#include "scan/blendshapes.h"

namespace bareskin {
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

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

void ModelFilesOptions::check() const {
  if (output.empty()) throw InvalidInput("-o", "names no model file", "e.g. -o model.safetensors");
  if (maps_res < 0) throw InvalidInput("--maps-res", "must not be negative", "0 transfers no maps");
  build.check();
}

std::string build_model_files(ModelFilesOptions o, const ModelFilesHooks& hooks) {
  const auto t0 = std::chrono::steady_clock::now();
  o.check();
  const auto progress = [&hooks](const std::string& stage) { return hooks.progress ? hooks.progress(stage) : ProgressCallback(); };
  const fs::path out_dir = fs::path(o.output).parent_path();
  if (o.registered.empty()) o.registered = (out_dir / "registered").string();
  o.template_dir = find_template_folder(o.template_dir);
  const TemplateFace face = read_template_folder(o.template_dir);

  std::vector<std::string> subjects;
  double register_seconds = 0;
  if (!o.scans.empty()) {
    RegisterFolderOptions reg;
    reg.scans = o.scans;
    reg.output = o.registered;
    reg.maps.resolution = o.maps_res;
    if (o.maps_res > 0) reg.maps.check();
    if (o.build.appearance_components > 0 && o.maps_res == 0) {
      throw InvalidInput("", "--maps-res 0 leaves no diffuse maps for the appearance model",
                         "give --maps-res 1024, or --appearance-components 0");
    }
    reg.detect = hooks.detect;
    subjects = register_folder(face, reg, progress("scan register"));  // the stage's progress ends with the call
    if (hooks.registered) hooks.registered(reg.output);
    register_seconds = seconds_since(t0);
  } else {
    subjects = registered_subjects(o.registered);
  }
  std::vector<NamedShape> blendshapes;
  for (const Blendshape& b : o.blendshapes.empty() ? make_blendshapes(face) : read_blendshapes(o.blendshapes)) {
    blendshapes.push_back({b.name, b.delta});
  }

  BuildReport report;
  MorphableModel model = build_model(face, subjects, blendshapes, o.build, report, progress("mm-build"));
  model.metadata["provenance"] = fmt::format("{}: {} subjects from {}, template {}", o.generator, subjects.size(),
                                             o.registered, o.template_dir);
  model.metadata["config"] = nlohmann::json{{"procrustes_scale", o.build.procrustes_scale},
                                            {"shape_variance", o.build.shape_variance},
                                            {"appearance_resolution", o.build.appearance_resolution},
                                            {"blendshapes", o.blendshapes.empty() ? "template set" : o.blendshapes}}
                                 .dump();
  const auto t_write = std::chrono::steady_clock::now();
  if (!out_dir.empty()) make_directories(out_dir.string());
  write_model(o.output, model);
  const double write_seconds = seconds_since(t_write);
  if (!o.export_obj.empty()) export_model_previews(o.export_obj, model);

  nlohmann::json summary = {
      {"model", o.output},
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
                   {"total", seconds_since(t0)}}}};
  const std::string stem = (out_dir / fs::path(o.output).stem()).string();
  write_file_atomic(stem + ".build.json", summary.dump(1) + "\n");
  spdlog::info("mm-build: {} subjects -> {} ({} identity, {} expression, {} appearance components; {:.1f}% / {:.1f}% "
               "of shape / appearance variance); {:.1f} s (read {:.1f}, GPA {:.1f}, PCA {:.1f}, maps {:.1f}, "
               "appearance PCA {:.1f})",
               report.subjects, o.output, model.shape_basis.rows(), model.expression_basis.rows(),
               model.appearance_basis.rows(), 100 * report.shape_variance_explained,
               100 * report.appearance_variance_explained, summary["seconds"]["total"].get<double>(),
               report.seconds_read_shapes, report.seconds_gpa, report.seconds_shape_pca, report.seconds_read_maps,
               report.seconds_appearance_pca);
  return stem;
}

}  // namespace bareskin
