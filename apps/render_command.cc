// bareskin render: pictures of a mesh (shaded + wireframe + landmarks from front/left/right, or its UV layout).
#include <algorithm>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "apps/cli.h"
#include "core/files.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "core/safetensors.h"
#include "render/preview.h"

namespace bareskin::cli {

std::function<void()> setup_render_command(CLI::App& app, const Globals&) {
  struct Options {
    std::string mesh, output, landmarks, blendshapes, texture;
    std::vector<std::string> expression;
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
  app.add_option("--blendshapes", opt->blendshapes, "blendshapes.safetensors (from 'scan synth') to pose the mesh with")
      ->check(CLI::ExistingFile)->group("Expression");
  app.add_option("--expression", opt->expression, "NAME=WEIGHT pairs, e.g. jawOpen=1,mouthSmile_L=0.5")
      ->delimiter(',')->group("Expression");
  app.add_option("--texture", opt->texture, "Diffuse map in the mesh's UV (e.g. scans/subject_0000/diffuse.png)")
      ->check(CLI::ExistingFile);
  app.add_flag("--no-wireframe", opt->no_wireframe, "Shading only");
  app.add_flag("--no-shading", opt->no_shading, "Wireframe only");
  return [opt] {
    Mesh mesh = read_mesh(opt->mesh);
    if (!opt->expression.empty() && opt->blendshapes.empty()) {
      throw InvalidInput("", "--expression needs --blendshapes FILE", "pass scans/blendshapes/blendshapes.safetensors");
    }
    if (!opt->blendshapes.empty()) {
      const SafeTensors st = SafeTensors::open(opt->blendshapes);
      const TensorView& deltas = st.tensor("deltas", DType::F32, {-1, mesh.V.rows(), 3});
      const auto names = nlohmann::json::parse(st.metadata().count("names") ? st.metadata().at("names") : "", nullptr, false);
      if (names.is_discarded() || !names.is_array() || int64_t(names.size()) != deltas.shape[0]) {
        throw InvalidInput(opt->blendshapes, "metadata 'names' does not list the blendshapes", "rewrite it with 'scan synth'");
      }
      const std::vector<float> d = deltas.to_vector<float>();
      for (const std::string& item : opt->expression) {
        const size_t eq = item.find('=');
        const std::string name = item.substr(0, eq);
        double weight = 1.0;
        if (eq != std::string::npos) {
          try {
            weight = std::stod(item.substr(eq + 1));
          } catch (const std::exception&) {
            throw InvalidInput("", "--expression '" + item + "': weight is not a number", "write NAME=WEIGHT");
          }
        }
        const auto it = std::find(names.begin(), names.end(), name);
        if (it == names.end()) throw InvalidInput(opt->blendshapes, "has no blendshape '" + name + "'", "see its names.json");
        const size_t k = size_t(it - names.begin()), n = size_t(mesh.V.rows());
        for (size_t i = 0; i < n; ++i)
          for (int c = 0; c < 3; ++c) mesh.V(Eigen::Index(i), c) += weight * d[(k * n + i) * 3 + size_t(c)];
      }
      mesh.N.resize(0, 3);  // recomputed for the posed shape
    }
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
    Image texture;
    if (!opt->texture.empty()) {
      texture = read_image(opt->texture);
      opt->preview.texture = &texture;
    }
    write_image(opt->output, render_preview(mesh, opt->preview));
  };
}

}  // namespace bareskin::cli
