// bareskin: one dispatcher for every command. Links named after a command (uvtools, render, ...) run that command.
#include "apps/cli.h"

// The light `bareskin` (BARESKIN_TORCH_EXECUTABLE names its sibling; apps/CMakeLists.txt) is built without LibTorch.
// Its table keeps every command's name, group and summary, for --help, but the commands that reach the Torch side have
// no setup there: apps/cli.cc hands their command lines to the sibling, which holds every command.
#ifdef BARESKIN_TORCH_EXECUTABLE
#define TORCH_SIDE(setup) nullptr
#else
#define TORCH_SIDE(setup) setup
#endif

namespace bareskin::cli {

std::function<void()> setup_template_command(CLI::App&, const Globals&);
std::function<void()> setup_inspect_command(CLI::App&, const Globals&);
std::function<void()> setup_render_command(CLI::App&, const Globals&);
std::function<void()> setup_scan_command(CLI::App&, const Globals&);
std::function<void()> setup_mm_build_command(CLI::App&, const Globals&);
std::function<void()> setup_mm_eval_command(CLI::App&, const Globals&);
std::function<void()> setup_mm_fit_command(CLI::App&, const Globals&);
std::function<void()> setup_uvtools_command(CLI::App&, const Globals&);
std::function<void()> setup_texgen_command(CLI::App&, const Globals&);
std::function<void()> setup_makeup_command(CLI::App&, const Globals&);
std::function<void()> setup_relight_command(CLI::App&, const Globals&);
std::function<void()> setup_viewer_command(CLI::App&, const Globals&);
#ifdef BARESKIN_WITH_DETECT
std::function<void()> setup_landmarks_command(CLI::App&, const Globals&);
std::function<void()> setup_train_command(CLI::App&, const Globals&);
std::function<void()> setup_recon_command(CLI::App&, const Globals&);
std::function<void()> setup_demakeup_command(CLI::App&, const Globals&);
#endif
#ifdef BARESKIN_WITH_AVATAR
std::function<void()> setup_run_command(CLI::App&, const Globals&);
std::function<void()> setup_evaluate_command(CLI::App&, const Globals&);
#endif

const std::vector<Command>& commands() {
  static const std::vector<Command> table = {
      {"template", "Setup", "Build the dense template face from the MediaPipe canonical face", setup_template_command},
      {"scan", "Scans", "Synthetic scans with ground truth (synth); registration to the template (register)",
       TORCH_SIDE(setup_scan_command)},
      {"mm-build", "Model", "Build the morphable model (GPA, identity/appearance PCA, expression basis) from scans",
       TORCH_SIDE(setup_mm_build_command)},
      {"mm-eval", "Model", "Model metrics: compactness, generalisation, specificity (CSV, JSON, SVG charts)",
       TORCH_SIDE(setup_mm_eval_command)},
      {"uvtools", "Maps",
       "UV-space tools: bake (map sets resized, seam-aware), unwarp (image into UV), mask (UV masks), mean (of maps)",
       setup_uvtools_command},
      {"mm-fit", "Model", "Fit the model to a photo: pose and shape from 68 landmarks, then appearance and light",
       TORCH_SIDE(setup_mm_fit_command)},
      {"texgen", "Data", "Training data: faces with makeup and truth, texture samples, real photo pairs, contact sheets",
       TORCH_SIDE(setup_texgen_command)},
#ifdef BARESKIN_WITH_DETECT
      {"landmarks", "Images", "68 landmarks: in a photo (detect), on a scan (scan, calibrate), synthetic rig photos",
       TORCH_SIDE(setup_landmarks_command)},
      {"train", "Training", "Train F/E, BareSkinNet, pix2pixHD, SRGAN; the network zoo; run weights for Python (export)",
       TORCH_SIDE(setup_train_command)},
      {"recon", "Images", "3DMM coefficients, light, mesh and a confidence from one photo by the network F or E",
       TORCH_SIDE(setup_recon_command)},
      {"demakeup", "Images", "BareSkinNet on photos: bare-skin image, 3DMM coefficients, unlit render, bare skin in UV",
       TORCH_SIDE(setup_demakeup_command)},
#endif
#ifdef BARESKIN_WITH_AVATAR
      {"run", "Avatar", "Photo -> relightable avatar: bare skin, 3DMM, four UV maps at 1K and 4K, OBJ + GLB, previews",
       TORCH_SIDE(setup_run_command)},
      {"evaluate", "Avatar", "The paper's Table 1: texture maps with and without BareSkinNet (RMSE, PSNR, SSIM)",
       TORCH_SIDE(setup_evaluate_command)},
#endif
      {"render", "Rendering", "Draw a mesh or the model: previews with landmarks, UV layout, camera passes (colour, depth...)",
       setup_render_command},
      {"makeup", "Avatar", "Makeup looks on an avatar folder: list, show, apply (one look, several, all)",
       setup_makeup_command},
      {"relight", "Avatar", "Render an avatar folder with its four maps under an SH, HDR or key light; export the photo's light",
       setup_relight_command},
      {"viewer", "Avatar", "An avatar folder's offline viewer.html: the GLB, a light to turn, bare / made-up / photo unwrap",
       setup_viewer_command},
      {"inspect", "Files", "Describe meshes, images, safetensors and landmark files", setup_inspect_command},
  };
  return table;
}

}  // namespace bareskin::cli

int main(int argc, char** argv) { return bareskin::cli::run(argc, argv); }
