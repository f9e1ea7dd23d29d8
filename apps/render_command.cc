// bareskin render: pictures of a mesh (morphable/render_files.h). Previews (shaded + wireframe + landmarks from
// front/left/right, or its UV layout), or with --camera the renderer proper: a pinhole or weak-perspective camera, SH
// lighting, and the passes colour, albedo, depth, normal and mask from one rasterization.
#include <memory>

#include "apps/cli.h"
#include "morphable/render_files.h"

namespace bareskin::cli {

namespace {
struct RenderArgs {
  RenderFilesOptions files;
  bool no_wireframe = false, no_shading = false;
};
}  // namespace

std::function<void()> setup_render_command(CLI::App& app, const Globals&) {
  auto args = std::make_shared<RenderArgs>();
  RenderFilesOptions* opt = &args->files;
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
  app.add_flag("--no-wireframe", args->no_wireframe, "Shading only");
  app.add_flag("--no-shading", args->no_shading, "Wireframe only");
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
  return [args, sh_option] {
    args->files.preview.wireframe = !args->no_wireframe;
    args->files.preview.shaded = !args->no_shading;
    args->files.sh_given = sh_option->count() > 0;
    render_files(args->files);
  };
}

}  // namespace bareskin::cli
