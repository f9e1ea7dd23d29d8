// bareskin template: builds the dense template face from the MediaPipe canonical face fetched at setup.
#include <cstdlib>
#include <filesystem>
#include <memory>

#include "apps/cli.h"
#include "core/assets.h"
#include "core/files.h"
#include "core/error.h"
#include "template/template_face.h"

namespace bareskin::cli {

struct TemplateCommandOptions {
  std::string assets;  // empty: the search path of core/assets.h
  std::string output = "template";
  TemplateOptions refine;
};

std::function<void()> setup_template_command(CLI::App& app, const Globals& globals) {
  auto opt = std::make_shared<TemplateCommandOptions>();
  app.add_option("-o,--output", opt->output, "Output directory (face.obj, landmarks.json, regions.json, face.safetensors, nodes.safetensors)")
      ->capture_default_str();
  app.add_option("--assets", opt->assets, "Folder filled by 'make deps' (default: BARESKIN_ASSETS, then the installed "
                                          "assets, then the source tree's; docs/cli.md)");
  app.add_option("--vertices", opt->refine.target_vertices, "Vertex count of the dense template (about)")
      ->capture_default_str()->group("Refinement");
  app.add_option("--remesh-iterations", opt->refine.remesh_iterations, "Isotropic remeshing passes")
      ->capture_default_str()->group("Refinement");
  return [opt, &globals] {
    opt->refine.check();
    const std::string assets = find_data_dir(DataKind::Assets, opt->assets, "mediapipe_face_mesh");
    const std::string mp = assets + "/mediapipe_face_mesh", human = assets + "/human";
    const std::string bundle_path = mp + "/face_mesh_solution_packed_assets.data";
    const std::string loader_path = mp + "/face_mesh_solution_packed_assets_loader.js";
    const std::string tables_path = human + "/facemeshcoords.ts";
    for (const std::string& p : {bundle_path, loader_path, tables_path}) {
      if (!std::filesystem::exists(p)) throw IoError(p, "asset not found", "run 'make deps' (or pass --assets DIR)");
    }
    const CanonicalFace canonical = decode_canonical_face(
        extract_packed_asset(read_file(bundle_path), read_file(loader_path), "geometry_pipeline_metadata_landmarks.binarypb",
                             bundle_path),
        bundle_path);
    const TemplateFace coarse = coarse_template(canonical, parse_face_mesh_tables(read_file(tables_path), tables_path));
    ProgressBar bar = globals.progress("template");
    const TemplateFace dense = refine_template(coarse, opt->refine, bar.callback());
    bar.finish();

    AtomicDirectory out(opt->output);
    write_template(out.path(), dense,
                   "MediaPipe canonical face (npm @mediapipe/face_mesh@0.4.1657299874, Apache-2.0) + iBUG-68/regions "
                   "from npm @vladmandic/human@3.3.6 (MIT), refined to " +
                       std::to_string(dense.mesh.V.rows()) + " vertices");
    for (const char* notice : {"/mediapipe_face_mesh/NOTICE", "/human/LICENSE"}) {
      const std::string src = assets + notice;
      if (std::filesystem::exists(src)) {
        write_file_atomic(out.path() + "/" + std::filesystem::path(notice).parent_path().filename().string() + "." +
                              std::filesystem::path(notice).filename().string(),
                          read_file(src));
      }
    }
    globals.write_resolved_config(out.path() + "/config.json");
    out.commit();
    spdlog::info("template: {} vertices, {} triangles -> {}", dense.mesh.V.rows(), dense.mesh.F.rows(), opt->output);
  };
}

}  // namespace bareskin::cli
