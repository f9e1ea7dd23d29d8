// bareskin demakeup: photo(s) → detect → align → G → F → bare-skin image, coefficients, unlit 3DMM render, bare
// skin in the template UV (bareskinnet/bareskinnet.h's demakeup). docs/cli.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <map>

#include "apps/cli.h"
#include "apps/device_flag.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/png.h"
#include "bareskinnet/bareskinnet.h"
#include "training/device.h"

namespace bareskin::cli {
namespace fs = std::filesystem;

namespace {

bool is_photo(const fs::path& p) {
  std::string ext = p.extension().string();
  for (auto& c : ext) c = char(std::tolower(c));
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
}

// --timing: per stage the median over the photos (the first left out as the warm-up when there are several).
void print_timing(const std::vector<std::map<std::string, double>>& runs) {
  const size_t first = runs.size() > 1 ? 1 : 0;
  std::printf("stage      median ms (%zu photo(s)%s)\n", runs.size() - first, first ? ", after a warm-up" : "");
  for (const char* stage : {"read", "detect", "align", "G", "F", "render", "unwarp", "write", "total"}) {
    std::vector<double> v;
    for (size_t i = first; i < runs.size(); ++i)
      if (auto it = runs[i].find(stage); it != runs[i].end()) v.push_back(it->second);
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    std::printf("%-10s %9.1f\n", stage, v[v.size() / 2]);
  }
}

}  // namespace

std::function<void()> setup_demakeup_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string input, output, run, teacher, model, device = "cpu";
    int64_t uv_size = 1024;
    int detector_size = 416;
    bool keep_going = false, aligned = false, without_g = false, timing = false;
  };
  auto o = std::make_shared<Options>();
  app.add_option("input", o->input, "A photo (PNG/JPEG/TIFF) or a folder of photos")->required();
  app.add_option("-o,--output", o->output, "Output folder (one subfolder per photo when the input is a folder)")->required();
  app.add_option("--run", o->run, "The 'bareskin train bareskin' run folder (G; names F and the model)")->required();
  app.add_option("--teacher", o->teacher, "The teacher F's run (default: the one the run was trained with)");
  app.add_option("--model", o->model, "The morphable model (default: the one the run was trained with)");
  app.add_option("--uv-size", o->uv_size, "Side of the UV map the bare skin is unwrapped into")->capture_default_str()
      ->check(CLI::Range(16, 16384));
  app.add_option("--detector-size", o->detector_size, "Face detector input (multiple of 32)")->capture_default_str();
  add_device_option(app, o->device);
  app.add_flag("--aligned", o->aligned, "The inputs are aligned 256² faces (texgen faces' makeup.png): no detection");
  app.add_flag("--without-g", o->without_g, "Skip G (the baseline: F's fit and the unwrap of the input itself, through "
               "G's resize round trip)");
  app.add_flag("--keep-going", o->keep_going, "With a folder: skip photos that fail and list them at the end");
  app.add_flag("--timing", o->timing, "Print the median wall milliseconds per stage over the photos (read, detect, "
               "align, G, F, render, unwarp, write, total; the first photo of several is the warm-up)");
  app.footer("Outputs: aligned.png (the 256² input G saw), bare.png (bare skin), unlit.png (the fit's albedo render), "
             "coefficients.json (F's fit: the coefficient file), uv.png + uv_mask.png (bare skin in the template UV).\n"
             "Example:\n  bareskin demakeup photo.jpg --run runs/bsn -o out/");
  return [o, &globals] {
    set_torch_threads(globals);
    const torch::Device device = parse_device(o->device);
    if (!fs::exists(o->input)) throw IoError(o->input, "does not exist", "give a photo or a folder of photos");
    std::vector<fs::path> photos;
    const bool folder = fs::is_directory(o->input);
    if (folder) {
      for (const auto& e : fs::directory_iterator(o->input))
        if (e.is_regular_file() && is_photo(e.path())) photos.push_back(e.path());
      std::sort(photos.begin(), photos.end());
      if (photos.empty()) throw InvalidInput(o->input, "holds no PNG/JPEG/TIFF photo", "give a photo or a folder of photos");
    } else {
      photos.push_back(o->input);
    }
    const detect::PhotoDetector detector = o->aligned ? detect::PhotoDetector() : photo_detector(globals, o->detector_size);
    auto read_aligned = [](const std::string& photo) {
      Image image = read_image(photo);
      if (image.channels < 3) throw InvalidInput(photo, "is not an RGB photo", "give a colour photo");
      if (image.width != detect::kAlignedSize || image.height != detect::kAlignedSize)
        throw InvalidInput(photo, "is " + std::to_string(image.width) + "×" + std::to_string(image.height) + ", not an aligned " +
                                      std::to_string(detect::kAlignedSize) + "² face", "drop --aligned for photos");
      return image;
    };
    if (o->aligned && !folder) read_aligned(photos[0].string());  // a wrong size fails before the networks load
    if (!folder && !o->aligned) {  // a photo without a face fails before the networks load
      Image image = read_image(photos[0].string());
      if (image.channels < 3) throw InvalidInput(photos[0].string(), "is not an RGB photo", "give a colour photo");
      if (detector(image).empty()) throw InvalidInput(photos[0].string(), "no face was found", "give a photo with a face of at least ~80 px");
    }
    bsn::Demakeup d = bsn::Demakeup::load(o->run, o->teacher, o->model, device);
    d.skip_g = o->without_g;
    std::vector<std::string> failed;
    std::vector<std::map<std::string, double>> timings;
    auto bar = globals.progress("demakeup");
    for (size_t i = 0; i < photos.size(); ++i) {
      const std::string photo = photos[i].string();
      try {
        const std::string dir = folder ? o->output + "/" + photos[i].stem().string() : o->output;
        using Clock = std::chrono::steady_clock;
        const auto t0 = Clock::now();
        auto ms_since = [](Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); };
        const Image image = o->aligned ? read_aligned(photo) : read_image(photo);
        if (image.channels < 3) throw InvalidInput(photo, "is not an RGB photo", "give a colour photo");
        const double read_ms = ms_since(t0);
        bsn::DemakeupResult r = o->aligned ? bsn::demakeup_aligned(d, bsn::image_tensor(image), o->uv_size)
                                           : bsn::demakeup(d, image, detector, o->uv_size, photo);
        const auto t1 = Clock::now();
        bsn::write_demakeup(r, d, dir, photo, !o->aligned);
        r.ms["write"] = ms_since(t1);
        r.ms["read"] = read_ms;
        r.ms["total"] = ms_since(t0);
        timings.push_back(r.ms);
      } catch (const Error& e) {
        if (!o->keep_going || !folder) throw;
        failed.push_back(e.what());
      }
      bar.update(int64_t(i + 1), int64_t(photos.size()), photos[i].filename().string());
    }
    bar.finish();
    if (o->timing && !timings.empty()) print_timing(timings);
    for (const auto& f : failed) std::cerr << "skipped: " << f << "\n";
    if (!globals.quiet()) std::cerr << "wrote " << o->output << " (" << photos.size() - failed.size() << " of " << photos.size() << " photos)\n";
    if (!failed.empty()) throw InvalidInput(o->input, std::to_string(failed.size()) + " photo(s) failed (listed above)", "");
  };
}

}  // namespace bareskin::cli
