// bareskin render: pictures of a mesh (shaded + wireframe + landmarks from front/left/right, or its UV layout).
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "apps/cli.h"
#include "core/files.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "render/preview.h"

namespace bareskin::cli {

std::function<void()> setup_render_command(CLI::App& app, const Globals&) {
  struct Options {
    std::string mesh, output, landmarks;
    std::string view = "front";
    PreviewOptions preview;
    bool no_wireframe = false, no_shading = false;
  };
  auto opt = std::make_shared<Options>();
  app.add_option("mesh", opt->mesh, "Mesh to draw (.obj or .ply)")->required()->check(CLI::ExistingFile);
  app.add_option("-o,--output", opt->output, "Output image (.png, .jpg, .exr)")->required();
  app.add_option("--view", opt->view, "front, left, right or uv (the UV layout)")
      ->capture_default_str()->check(CLI::IsMember({"front", "left", "right", "uv"}));
  app.add_option("--size", opt->preview.size, "Image size in pixels")->capture_default_str()->check(CLI::Range(16, 16384));
  app.add_option("--landmarks", opt->landmarks, "Landmark JSON with \"vertex_ids\" (e.g. template/landmarks.json)");
  app.add_flag("--no-wireframe", opt->no_wireframe, "Shading only");
  app.add_flag("--no-shading", opt->no_shading, "Wireframe only");
  return [opt] {
    const Mesh mesh = read_mesh(opt->mesh);
    opt->preview.view = parse_preview_view(opt->view);
    opt->preview.wireframe = !opt->no_wireframe;
    opt->preview.shaded = !opt->no_shading;
    if (!opt->landmarks.empty()) {
      const auto doc = nlohmann::json::parse(read_file(opt->landmarks), nullptr, false);
      if (doc.is_discarded() || !doc.contains("vertex_ids") || !doc["vertex_ids"].is_array()) {
        throw InvalidInput(opt->landmarks, "has no \"vertex_ids\" list", "pass the template's landmarks.json");
      }
      for (const auto& id : doc["vertex_ids"]) {
        if (!id.is_number_integer() || id.get<int>() < 0 || id.get<int>() >= mesh.V.rows()) {
          throw InvalidInput(opt->landmarks, "vertex_ids names a vertex outside " + opt->mesh, "use the mesh's own landmarks");
        }
        opt->preview.landmark_vertices.push_back(id.get<int>());
      }
    }
    write_image(opt->output, render_preview(mesh, opt->preview));
  };
}

}  // namespace bareskin::cli
