// bareskin recon: a photo → face-api's 68 landmarks → recon/recon_photo.h (Deep3DFaceRecon's 5-point alignment, the
// net F or E of a `bareskin train recon` run, --refine: mm-fit's fitters from the net's answer) → coefficient file,
// posed mesh (OBJ), overlay picture, landmarks, and a confidence. This file parses flags. docs/cli.md.
#include <filesystem>
#include <iostream>

#include "apps/cli.h"
#include "apps/device_flag.h"
#include "apps/detector.h"
#include "training/device.h"
#include "recon/recon_eval.h"
#include "core/error.h"
#include "core/image_io.h"
#include "detect/align.h"
#include "recon/recon_photo.h"

namespace bareskin::cli {
namespace fs = std::filesystem;

std::function<void()> setup_recon_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string input, output, run, model, device = "cpu";
    bool keep_going = false;
    recon::PhotoReconOptions photo;  // its confidence is --eval's too
    recon::EvalOptions eval;
  };
  auto o = std::make_shared<Options>();
  app.add_option("photo", o->input, "A photo (PNG, JPEG, TIFF) or a folder of photos");
  app.add_option("-o,--output", o->output, "Output folder (per photo a subfolder when the input is a folder)")->required();
  app.add_option("--run", o->run, "The net: a 'bareskin train recon' run folder or its checkpoint")->required();
  app.add_option("--model", o->model, "The morphable model (default: the one the run was trained with)");
  app.add_flag("--refine", o->photo.refine, "Continue with mm-fit's fitters from the net's answer (landmarks, then appearance "
                                      "and light)");
  app.add_option("--refine-iterations", o->photo.refine_iterations, "Landmark-fit iterations of --refine")->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_flag("--keep-going", o->keep_going, "With a folder: report a photo that fails and go on (exit 3 at the end)");
  app.add_option("--flag-landmark-px", o->photo.confidence.landmark_px, "Flag answers whose landmarks are further than this "
                                                                  "from the detector's (px, 256² frame)")->capture_default_str();
  app.add_option("--flag-psnr", o->photo.confidence.psnr_db, "Flag answers whose render matches the photo worse than this "
                                                       "(dB)")->capture_default_str();
  app.add_option("--eval", o->eval.data, "Instead of photos: held-out face samples (a split of 'texgen faces') to "
                                         "measure against their truth and mm-fit (metrics.json, charts, heat maps)");
  app.add_option("--eval-faces", o->eval.max_faces, "With --eval: at most this many samples (0: all)")->capture_default_str();
  app.add_option("--eval-input", o->eval.input, "With --eval: the member the net sees (before or makeup)")
      ->check(CLI::IsMember({"before", "makeup"}))->capture_default_str();
  add_device_option(app, o->device);
  app.footer("Outputs: coefficients.json (the coefficient file, with confidence), mesh.obj, overlay.png, aligned.png,\n"
             "landmarks.json. Example:\n  bareskin recon photo.jpg --run runs/F -o out/\n");
  return [o, &globals] {
    set_torch_threads(globals);
    const torch::Device device = parse_device(o->device);
    if (o->input.empty() == o->eval.data.empty()) {
      throw CLI::ValidationError("recon", "give a photo (or folder), or --eval with face samples");
    }
    if (!o->eval.data.empty()) {
      recon::EvalOptions e = o->eval;
      e.run = o->run;
      e.model = o->model;
      e.output = o->output;
      e.confidence = o->photo.confidence;
      auto bar = globals.progress("recon eval");
      const nlohmann::json summary = recon::evaluate_recon(e, bar.callback());
      bar.finish();
      if (!globals.quiet()) std::cout << summary.dump(2) << "\n";
      return;
    }
    recon::PhotoFilesOptions p;
    p.input = o->input;
    p.output = o->output;
    p.run = o->run;
    p.model = o->model;
    p.device = device;
    p.recon = o->photo;
    p.keep_going = o->keep_going;
    p.quiet = globals.quiet();
    recon::reconstruct_photo_files(p);
  };
}

}  // namespace bareskin::cli
