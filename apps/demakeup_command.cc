// bareskin demakeup: photo(s) → detect → align → G → F → bare-skin image, coefficients, unlit 3DMM render, bare
// skin in the template UV (bareskinnet/demakeup_files.h). docs/cli.md.
#include <cstdio>
#include <iostream>

#include "apps/cli.h"
#include "apps/detector.h"
#include "apps/device_flag.h"
#include "bareskinnet/demakeup_files.h"
#include "training/device.h"

namespace bareskin::cli {

std::function<void()> setup_demakeup_command(CLI::App& app, const Globals& globals) {
  struct Options {
    bsn::DemakeupFilesOptions files;
    int detector_size = detect::kDetectorInputSize;
    bool timing = false;
  };
  auto o = std::make_shared<Options>();
  bsn::DemakeupFilesOptions& f = o->files;
  app.add_option("input", f.input, "A photo (PNG/JPEG/TIFF) or a folder of photos")->required();
  app.add_option("-o,--output", f.output, "Output folder (one subfolder per photo when the input is a folder)")->required();
  app.add_option("--run", f.run, "The 'bareskin train bareskin' run folder (G; names F and the model)")->required();
  app.add_option("--teacher", f.teacher, "The teacher F's run (default: the one the run was trained with)");
  app.add_option("--model", f.model, "The morphable model (default: the one the run was trained with)");
  app.add_option("--uv-size", f.uv_size, "Side of the UV map the bare skin is unwrapped into")->capture_default_str()
      ->check(CLI::Range(16, 16384));
  app.add_option("--detector-size", o->detector_size, "Face detector input (multiple of 32)")->capture_default_str();
  add_device_option(app, f.device);
  app.add_flag("--aligned", f.aligned, "The inputs are aligned 256² faces (texgen faces' makeup.png): no detection");
  app.add_flag("--without-g", f.without_g, "Skip G (the baseline: F's fit and the unwrap of the input itself)");
  app.add_flag("--flip-average", f.flip_average, "Average G's image with its image of the mirrored photo (twice G's "
               "time; bare.png +0.27 dB on held-out faces, F's albedo of it -0.7 dB)");
  app.add_flag("--keep-going", f.keep_going, "With a folder: skip photos that fail and list them at the end");
  app.add_flag("--timing", o->timing, "Print the median wall milliseconds per stage over the photos (read, detect, "
               "align, G, F, render, unwarp, write, total; the first photo of several is the warm-up)");
  app.footer("Outputs: aligned.png (the 256² input G saw), bare.png (bare skin), unlit.png (the fit's albedo render), "
             "coefficients.json (F's fit: the coefficient file), uv.png + uv_mask.png (bare skin in the template UV).\n"
             "Example:\n  bareskin demakeup photo.jpg --run runs/bsn -o out/");
  return [o, &globals] {
    set_torch_threads(globals);
    o->files.device = parse_device(o->files.device).str();
    const detect::PhotoDetector detector =
        o->files.aligned ? detect::PhotoDetector() : photo_detector(globals, o->detector_size);
    auto bar = globals.progress("demakeup");
    const bsn::DemakeupFilesReport r = bsn::demakeup_files(o->files, detector, bar.callback());
    bar.finish();
    if (o->timing && !r.ms.empty()) std::fputs(bsn::timing_table(r.ms).c_str(), stdout);
    if (!globals.quiet()) std::cerr << "wrote " << o->files.output << " (" << r.photos << " photos)\n";
  };
}

}  // namespace bareskin::cli
