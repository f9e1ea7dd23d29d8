// bareskin run: a face photo -> a relightable avatar folder (avatar/avatar.h; docs/texture.md).
#include <chrono>
#include <iostream>
#include <memory>
#include <thread>

#include "apps/cli.h"
#include "apps/detector.h"
#include "apps/device_flag.h"
#include "core/error.h"
#include "core/files.h"
#include "core/parallel.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "detect/align.h"
#include "detect/face_api.h"
#include "avatar/avatar.h"
#include "training/device.h"

namespace bareskin::cli {

std::function<void()> setup_run_command(CLI::App& app, const Globals& globals) {
  struct Options {
    texture::RunFilesOptions run;
    bool no_bareskin = false, no_upscale = false;
  };
  auto opt = std::make_shared<Options>();
  texture::RunFilesOptions& run = opt->run;
  for (const std::string& m : run.avatar.sr_maps) run.sr_maps += (run.sr_maps.empty() ? "" : ",") + m;  // the default
  app.add_option("photo", run.photo, "Face photo (PNG/JPEG); the best face found is used")->required();
  app.add_option("-o,--output", run.output, "Avatar folder (written atomically: all or nothing)")->required();
  app.add_option("--model", run.model, "Morphable model (model.safetensors)")->required();
  app.add_option("--texture", run.texture, "pix2pixHD run (bareskin train texture)")->required();
  app.add_option("--upscale", run.upscale, "SRGAN runs (bareskin train upscale), one per map; maps without one are "
                                           "upscaled bicubically")
      ->expected(0, -1);
  app.add_option("--bareskin", run.bareskin, "BareSkinNet run (bareskin train bareskin): G before reconstruction "
                                             "(this or --no-bareskin is required)");
  app.add_option("--teacher", run.teacher, "Reconstruction net F (bareskin train recon run): the 3DMM coefficients "
                                           "from G's image; without it mm-fit's landmark and photometric fits");
  app.add_option("--sr-maps", run.sr_maps,
                 "Maps SRGAN upscales where an --upscale run is given for them (comma-separated; the others "
                 "bicubically: SRGAN gained nothing over bicubic on the smooth normal map, docs/texture.md)")
      ->capture_default_str();
  app.add_flag("--no-bareskin", opt->no_bareskin, "Skip G: the photo itself is reconstructed and unwrapped (this or "
                                                  "--bareskin is required)");
  app.add_flag("--no-upscale", opt->no_upscale, "Maps at the texture net's size only");
  app.add_option("--input-res", run.avatar.input_res, "UV size of the unwrap (0: the texture run's size)")
      ->capture_default_str()->check(CLI::Validator(
          [](std::string& text) {
            const int v = std::atoi(text.c_str());
            return v == 0 || (v >= 64 && v <= 8192) ? std::string() : std::string("must be 0 or lie in [64, 8192]");
          },
          "0 or 64..8192"));
  app.add_option("--preview-size", run.avatar.preview_size, "Relit previews' size")->capture_default_str()
      ->check(CLI::Range(16, 4096));
  add_device_option(app, run.device);
  app.add_option("--landmarks", run.landmarks,
                 "The photo's 68 landmarks (a landmark file, px): used instead of the detector (e.g. for aligned shards)");
  app.add_option("--weights", run.weights, "face-api's tfjs models (default: face_api/ in the assets)");
  app.add_option("--face-mask", run.face_mask,
                 "The photo's face segmentation (grey PNG at the photo's size, white = face skin, eyes, brows, lips; "
                 "black = hair, glasses, hands, background): unwrap texels touching black are left to the texture net");
  app.footer("Example: bareskin run photo.png -o avatar/ --model model.safetensors --texture runs/tex "
             "--upscale runs/up_diffuse --bareskin runs/bsn --teacher runs/F\nExit 3 (nothing written) for a photo without a face "
             "or runs that do not fit each other or the model.");
  return [opt, &globals] {
    set_torch_threads(globals);
    texture::RunFilesOptions& run = opt->run;
    run.device = parse_device(run.device).str();
    keep_freed_memory();
    if (opt->no_bareskin == !run.bareskin.empty())
      throw CLI::ValidationError("run", "give exactly one of --bareskin RUN and --no-bareskin");
    run.avatar.sr_maps = texture::parse_map_list(run.sr_maps, "--sr-maps");
    run.avatar.upscale = !opt->no_upscale;
    run.threads = std::max(1, globals.threads > 0 ? globals.threads : int(std::thread::hardware_concurrency()));
    const texture::RunFilesResult r = texture::run_files(run);
    if (!globals.quiet())
      std::cerr << "wrote " << run.output << " (" << fmt::format("{:.1f}", r.seconds) << " s; upscaled with "
                << (r.upscaled_with.empty() ? "none" : r.upscaled_with) << ")\n";
  };
}

}  // namespace bareskin::cli
