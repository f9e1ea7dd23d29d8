// bareskin uvtools: UV-space tools, one setup + run per subcommand. `bake`: a set of maps (up to 16K) resized to
// smaller sizes in one streamed pass, seam-aware with a layout (uvtools/bake.h). `unwarp`: an image into the mesh's UV
// through a camera, with visibility (uvtools/unwarp.h). `mask`: face-parsing labels or synthetic occluders into a UV
// mask (uvtools/mask.h). `mean`: the mean of maps in one UV layout, in linear light (uvtools/mean.h).
#include <cmath>
#include <filesystem>
#include <memory>
#include <sstream>

#include "apps/cli.h"
#include "core/error.h"
#include "core/files.h"
#include "morphable/uv_files.h"
#include "uvtools/bake.h"
#include "uvtools/mean.h"

namespace bareskin::cli {
namespace {

namespace fs = std::filesystem;

std::vector<int> parse_sizes(const std::string& text) {
  std::vector<int> sizes;
  std::stringstream list(text);
  for (std::string item; std::getline(list, item, ',');) {
    try {
      size_t used = 0;
      sizes.push_back(std::stoi(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw InvalidInput("", "--sizes: '" + item + "' is not a whole number", "give e.g. --sizes 4096,1024");
    }
  }
  return sizes;
}

std::function<void()> setup_bake(CLI::App& uvtools, const Globals& globals) {
  struct Options {
    std::string sizes;
    BakeFilesOptions bake;
  };
  auto opt = std::make_shared<Options>();
  for (int size : opt->bake.resize.sizes) opt->sizes += (opt->sizes.empty() ? "" : ",") + std::to_string(size);
  CLI::App* bake = uvtools.add_subcommand("bake", "Resize a set of UV maps (16K → 4K, 1K, ...) out of core, seam-aware");
  bake->add_option("input", opt->bake.input, "Folder with diffuse/normal/roughness/specular .exr|.tif|.png")->required();
  bake->add_option("-o,--output", opt->bake.output, "Output folder: <size>/<map>.<format>")->required();
  bake->add_option("--sizes", opt->sizes, "Output sizes, comma-separated; each must divide the input size")
      ->capture_default_str();
  bake->add_option("--layout", opt->bake.layout, "Mesh whose UV islands the maps follow (e.g. the template's face.obj): "
                                                 "seam-aware. Without it: a plain area-correct resize per map type");
  MapResizeOptions& resize = opt->bake.resize;
  bake->add_option("--format", resize.format, "exr (half, zip, tiled), png or tif (16-bit)")->capture_default_str();
  bake->add_flag("--mipmap", resize.mipmap, "EXR/TIFF: also write the mip chain");
  bake->add_flag("--toksvig", resize.toksvig, "Roughness absorbs the variance of the averaged normals");
  bake->add_option("--gutter", resize.gutter, "Output texels filled beyond the islands")->capture_default_str();
  return [opt, bake, &globals] {
    if (!bake->parsed()) return;
    opt->bake.resize.sizes = parse_sizes(opt->sizes);
    ProgressBar bar = globals.progress("uvtools bake");
    bake_files(opt->bake, bar.callback());
    bar.finish();
    globals.write_resolved_config(opt->bake.output + "/config.json");
  };
}

// unwarp's confidence map: <stem>_confidence<ext> beside the UV map.
std::function<void()> setup_unwarp(CLI::App& uvtools, const Globals& globals) {
  auto un = std::make_shared<UnwarpFilesOptions>();
  CLI::App* app = uvtools.add_subcommand("unwarp", "Sample an image into the mesh's UV through a camera, with visibility");
  app->alias("unwrap");  // the paper's word
  app->add_option("image", un->image, "Image (a render or a photo the mesh is fitted to)")->required();
  app->add_option("--mesh", un->mesh, "Mesh with UVs, posed as in the image");
  app->add_option("--model", un->model, "Or a morphable model (mm-build) ...");
  app->add_option("--coeffs", un->coeffs, "... at these coefficients (JSON: alpha, beta, rotation, translation)");
  app->add_option("-o,--output", un->output, "UV map, RGB (.exr linear, .png/.tif sRGB 16-bit); the confidence "
                                             "(cos of the view angle, 0 = unseen) goes beside it as <name>_confidence")
      ->required();
  app->add_option("--view", un->view, "Camera as 'render --view': front, left or right")->capture_default_str()
      ->check(CLI::IsMember({"front", "left", "right"}));
  app->add_option("--camera", un->camera, "pinhole or weak, as 'render --camera'")->capture_default_str()
      ->check(CLI::IsMember({"pinhole", "weak"}));
  app->add_option("--size", un->unwarp.size, "UV map size")->capture_default_str();
  app->add_option("--depth-tolerance", un->unwarp.depth_tolerance, "mm between a texel and the depth buffer")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  return [un, app] {
    if (!app->parsed()) return;
    const UnwarpResult r = unwarp_files(*un);
    spdlog::info("uvtools unwarp: {} of {} texels of the UV layout seen ({:.1f}%) -> {}", r.seen, r.in_layout,
                 100.0 * double(r.seen) / double(std::max<int64_t>(r.in_layout, 1)), un->output);
  };
}

std::function<void()> setup_mask(CLI::App& uvtools, const Globals& globals) {
  auto mk = std::make_shared<MaskFilesOptions>();
  CLI::App* app = uvtools.add_subcommand("mask", "Face-parsing labels (CelebAMask-HQ) → a UV mask of the seen, uncovered "
                                                 "face; or synthetic occluders (hair, glasses, hand, hat)");
  app->add_option("labels", mk->labels, "Label image: one channel of CelebAMask-HQ class indices (0-18, 19 = hand)");
  app->add_option("--mesh", mk->mesh, "Mesh with UVs, posed as in the image");
  app->add_option("--model", mk->model, "Or a morphable model (mm-build) ...");
  app->add_option("--coeffs", mk->coeffs, "... at these coefficients (JSON: alpha, beta, rotation, translation)");
  app->add_option("-o,--output", mk->output, "UV mask (8-bit PNG: 255 = face seen and uncovered)")->required();
  app->add_option("--view", mk->view, "Camera as 'render --view': front, left or right")->capture_default_str()
      ->check(CLI::IsMember({"front", "left", "right"}));
  app->add_option("--camera", mk->camera, "pinhole or weak")->capture_default_str()
      ->check(CLI::IsMember({"pinhole", "weak"}));
  app->add_option("--size", mk->size, "UV mask size")->capture_default_str();
  app->add_option("--synthetic", mk->synthetic, "Instead of a label image: the face as seen, covered by these "
                                                "occluders drawn at random (hair,glasses,hand,hat)")->group("Synthetic");
  app->add_option("--landmarks", mk->landmarks, "Landmark JSON with the mesh's \"vertex_ids\" (for --synthetic; "
                                                "a --model has its own)")
      ->group("Synthetic");
  app->add_option("--seed", mk->seed, "Random seed of the occluders' shapes")->capture_default_str()->group("Synthetic");
  app->add_option("--image-size", mk->image_size, "Size of the synthetic label image")->capture_default_str()
      ->check(CLI::Range(16, 8192))->group("Synthetic");
  app->add_option("--labels-out", mk->labels_out, "Also write the synthetic label image here (PNG)")->group("Synthetic");
  return [mk, app] {
    if (!app->parsed()) return;
    const int64_t kept = mask_files(*mk);
    spdlog::info("uvtools mask: {} texels of the face seen and uncovered -> {}", kept, mk->output);
  };
}

std::function<void()> setup_mean(CLI::App& uvtools, const Globals& globals) {
  struct Options {
    std::vector<std::string> maps;
    std::string output;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* app = uvtools.add_subcommand("mean", "The mean of maps in one UV layout, in linear light (e.g. the texture "
                                                 "reference of 'scan register --texture-landmarks')");
  app->add_option("maps", opt->maps, "Maps of one size in one UV layout, e.g. registered/*/diffuse.png; black texels "
                                     "(outside a map's transfer) do not count")
      ->required();
  app->add_option("-o,--output", opt->output, "The mean: .exr linear, .png/.tif sRGB; the first map's bit depth")->required();
  return [opt, app, &globals] {
    if (!app->parsed()) return;
    check_output_file(opt->output);
    check_output_apart(opt->output, opt->maps);
    ProgressBar bar = globals.progress("uvtools mean");
    const MapMean mean = mean_of_maps(opt->maps, bar.callback());
    bar.finish();
    write_map_mean(opt->output, mean);
    spdlog::info("uvtools mean: {} maps, {:.1f}% of the texels covered -> {}", opt->maps.size(),
                 100 * mean.covered_fraction, opt->output);
  };
}

}  // namespace

std::function<void()> setup_uvtools_command(CLI::App& app, const Globals& globals) {
  app.require_subcommand(1);
  const std::function<void()> runs[] = {setup_bake(app, globals), setup_unwarp(app, globals), setup_mask(app, globals),
                                        setup_mean(app, globals)};
  return [runs] {
    for (const auto& run : runs) run();  // each runs only when its subcommand was parsed
  };
}

}  // namespace bareskin::cli
