// bareskin render: pictures of a mesh. Previews (shaded + wireframe + landmarks from front/left/right, or its UV
// layout), or with --camera the renderer proper: a pinhole or weak-perspective camera, SH lighting, and the passes
// colour, albedo, depth, normal and mask from one rasterization.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <memory>

#include "apps/cli.h"
#include "apps/model_input.h"
#include "core/files.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "morphable/model.h"
#include "render/preview.h"
#include "render/shade.h"

namespace bareskin::cli {

namespace {

std::string expand(std::string pattern, const std::string& key, const std::string& value) {
  for (size_t at; (at = pattern.find(key)) != std::string::npos;) pattern.replace(at, key.size(), value);
  return pattern;
}

struct RenderArgs {
  std::string mesh, model, coeffs, output, landmarks, blendshapes, texture, landmarks_out;
  std::vector<std::string> expression;
  std::string view = "front";
  PreviewOptions preview;
  bool draw_landmarks = false;
  bool no_wireframe = false, no_shading = false;
  std::string camera, sh = "default";
  std::vector<std::string> views, passes = {"colour"};
  bool cull = false;
};

// --camera: every view's frame, its passes and projected landmarks.
void render_with_camera(const RenderArgs& opt, const Mesh& mesh, const ModelInstance& instance, bool sh_given) {
  const std::vector<std::string> views = opt.views.empty() ? std::vector<std::string>{opt.view} : opt.views;
  if ((views.size() > 1 && opt.output.find("{view}") == std::string::npos) ||
      (opt.passes.size() > 1 && opt.output.find("{pass}") == std::string::npos)) {
    throw InvalidInput("", "several views or passes need {view} / {pass} in -o", "e.g. -o out/face_{view}_{pass}.png");
  }
  ShadeOptions shade;
  shade.gamma = instance.gamma && !sh_given ? *instance.gamma : read_sh_lighting(opt.sh);
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
void render_preview_picture(RenderArgs& opt, const Mesh& mesh) {
  opt.preview.view = parse_preview_view(opt.view);
  opt.preview.wireframe = !opt.no_wireframe;
  opt.preview.shaded = !opt.no_shading;
  if (!opt.landmarks.empty()) opt.preview.landmark_vertices = read_landmark_vertex_ids(opt.landmarks, mesh);
  Image texture;
  if (!opt.texture.empty()) {
    texture = read_image(opt.texture);
    opt.preview.texture = &texture;
  }
  write_image(opt.output, render_preview(mesh, opt.preview));
}

}  // namespace

std::function<void()> setup_render_command(CLI::App& app, const Globals&) {
  auto opt = std::make_shared<RenderArgs>();
  app.add_option("mesh", opt->mesh, "Mesh to draw (.obj or .ply)")->check(CLI::ExistingFile);
  app.add_option("--model", opt->model, "Or a morphable model (mm-build) ...");
  app.add_option("--coeffs", opt->coeffs, "... at these coefficients (JSON: alpha, beta, delta, rotation, translation, "
                                          "gamma); with --camera its appearance and lighting are used");
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
  app.add_option("--camera", opt->camera, "Render with a camera instead of a preview: pinhole (Deep3DFaceRecon's, 1 m "
                                          "away) or weak")
      ->check(CLI::IsMember({"pinhole", "weak"}))->group("Camera");
  app.add_option("--views", opt->views, "With --camera: views to render (front,left,right); -o takes {view}")
      ->delimiter(',')->check(CLI::IsMember({"front", "left", "right"}))->group("Camera");
  app.add_option("--passes", opt->passes, "With --camera: colour, albedo, depth, normal, mask; -o takes {pass}")
      ->delimiter(',')->check(CLI::IsMember({"colour", "albedo", "depth", "normal", "mask"}))
      ->capture_default_str()->group("Camera");
  CLI::Option* sh_option = app.add_option("--sh", opt->sh, "With --camera: 'default' (Deep3DFaceRecon ambient + a soft key light), 'none' "
                                  "(ambient only) or a JSON file with 27 coefficients (RGB, 9 each)")
      ->capture_default_str()->group("Camera");
  app.add_flag("--cull", opt->cull, "With --camera: drop back faces")->group("Camera");
  app.add_option("--landmarks-out", opt->landmarks_out, "With --camera: the 68 landmarks projected into the image (JSON, "
                                                        "px; the model's, or --landmarks' vertex ids); may take {view}")
      ->group("Camera");
  app.add_flag("--draw-landmarks", opt->draw_landmarks, "With --camera: draw the 68 projected landmarks on the colour and "
                                                        "albedo passes (the model's, or --landmarks' vertex ids)")
      ->group("Camera");
  return [opt, sh_option] {
    if (opt->mesh.empty() == opt->model.empty()) {
      throw InvalidInput("", opt->mesh.empty() ? "give a mesh, or --model with --coeffs" : "give a mesh or --model, not both",
                         "see --help");
    }
    ModelInstance instance;
    if (!opt->model.empty()) instance = model_instance(opt->model, opt->coeffs);
    Mesh mesh = opt->model.empty() ? read_mesh(opt->mesh) : instance.mesh;
    pose_blendshapes(mesh, opt->blendshapes, opt->expression);
    if (!opt->camera.empty()) return render_with_camera(*opt, mesh, instance, sh_option->count() > 0);
    render_preview_picture(*opt, mesh);
  };
}

}  // namespace bareskin::cli
