// `bareskin render` on files (render_files.h): the mesh or the posed model, posed by blendshapes, then the preview
// picture or the camera's passes and projected landmarks.
#include "morphable/render_files.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "morphable/model.h"
#include "morphable/model_input.h"
#include "render/shade.h"

namespace bareskin {
namespace {

std::string expand(std::string pattern, const std::string& key, const std::string& value) {
  for (size_t at; (at = pattern.find(key)) != std::string::npos;) pattern.replace(at, key.size(), value);
  return pattern;
}

// --camera: every view's frame, its passes and projected landmarks.
void render_with_camera(const RenderFilesOptions& opt, const Mesh& mesh, const ModelInstance& instance) {
  const std::vector<std::string> views = opt.views.empty() ? std::vector<std::string>{opt.view} : opt.views;
  if ((views.size() > 1 && opt.output.find("{view}") == std::string::npos) ||
      (opt.passes.size() > 1 && opt.output.find("{pass}") == std::string::npos)) {
    throw InvalidInput("", "several views or passes need {view} / {pass} in -o", "e.g. -o out/face_{view}_{pass}.png");
  }
  ShadeOptions shade;
  shade.gamma = instance.gamma && !opt.sh_given ? *instance.gamma : read_sh_lighting(opt.sh);
  shade.cull_back_faces = opt.cull;
  Image texture;
  if (!opt.texture.empty()) {
    texture = read_image(opt.texture);
    if (texture.color_space == ColorSpace::sRGB) texture = to_linear(texture);
    shade.texture = &texture;
  } else if (!instance.appearance.empty()) {
    shade.texture = &instance.appearance;
  }
  std::vector<int> landmark_ids;  // for --landmarks-out and --draw-landmarks, checked before anything is written
  if (!opt.landmarks_out.empty() || opt.draw_landmarks) {
    landmark_ids = opt.landmarks.empty() ? instance.landmark_vertices : read_landmark_vertex_ids(opt.landmarks, mesh);
    if (landmark_ids.size() != 68) {
      throw InvalidInput(opt.landmarks, "--landmarks-out and --draw-landmarks need 68 landmark vertices, got " +
                                            std::to_string(landmark_ids.size()), "pass the template's landmarks.json as --landmarks");
    }
  }
  for (const std::string& view : views) {
    if (view == "uv") throw InvalidInput("", "--camera renders front, left or right views", "drop --camera for the UV layout");
    const Camera cam = command_camera(mesh, !opt.model.empty(), view, opt.camera, opt.preview.size);
    const Frame frame = render_frame(mesh, cam, shade);
    Landmarks lm;  // the 68 landmarks projected into this view, when asked for
    if (!landmark_ids.empty()) {
      lm.units = "px";
      lm.points.resize(68, 2);
      for (int k = 0; k < 68; ++k) {
        const Eigen::Vector3d p = cam.project(mesh.V.row(landmark_ids[size_t(k)]).transpose());
        lm.points.row(k) << p.x(), p.y();
      }
    }
    if (!opt.landmarks_out.empty()) write_landmarks(expand(opt.landmarks_out, "{view}", view), lm);
    if (frame.dropped_behind) spdlog::warn("render: {} triangles behind the camera were dropped", frame.dropped_behind);
    for (const std::string& pass : opt.passes) {
      const std::string path = expand(expand(opt.output, "{view}", view), "{pass}", pass);
      const bool exr = path.size() > 4 && path.substr(path.size() - 4) == ".exr";
      Image img = pass_image(frame, pass, exr);
      if ((pass == "colour" || pass == "albedo") && opt.draw_landmarks) {
        draw_landmarks(img, lm.points, {0.1f, 0.9f, 0.2f}, std::max(1, opt.preview.size / 200));
      }
      ImageWriteOptions w;
      if (!exr && (pass == "depth" || pass == "normal")) w.type = PixelType::UInt16;
      write_image(path, img, w);
    }
  }
}

// Without --camera: the preview picture (shaded + wireframe + landmarks, or the UV layout).
void render_preview_picture(const RenderFilesOptions& opt, const Mesh& mesh) {
  PreviewOptions preview = opt.preview;
  preview.view = parse_preview_view(opt.view);
  if (!opt.landmarks.empty()) preview.landmark_vertices = read_landmark_vertex_ids(opt.landmarks, mesh);
  Image texture;
  if (!opt.texture.empty()) {
    texture = read_image(opt.texture);
    preview.texture = &texture;
  }
  write_image(opt.output, render_preview(mesh, preview));
}

}  // namespace

void RenderFilesOptions::check() const {
  if (mesh.empty() == model.empty()) {
    throw InvalidInput("", mesh.empty() ? "give a mesh, or --model with --coeffs" : "give a mesh or --model, not both",
                       "see --help");
  }
  if (output.empty()) throw InvalidInput("-o", "names no output image", "e.g. -o face.png");
  if (!camera.empty() && camera != "pinhole" && camera != "weak")
    throw InvalidInput("--camera", "'" + camera + "' is neither pinhole nor weak", "e.g. --camera pinhole");
  preview.check();
}

void render_files(const RenderFilesOptions& opt) {
  opt.check();
  ModelInstance instance;
  if (!opt.model.empty()) instance = model_instance(opt.model, opt.coeffs);
  Mesh mesh = opt.model.empty() ? read_mesh(opt.mesh) : instance.mesh;
  pose_blendshapes(mesh, opt.blendshapes, opt.expression);
  if (!opt.camera.empty()) return render_with_camera(opt, mesh, instance);
  render_preview_picture(opt, mesh);
}

}  // namespace bareskin
