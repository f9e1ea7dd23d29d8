// bareskin demakeup: photo(s) → detect → align → G → F → bare-skin image, coefficients, unlit 3DMM render, bare
// skin in the template UV (training/bareskinnet.h's demakeup). docs/cli.md.
#include <filesystem>
#include <iostream>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/png.h"
#include "training/bareskinnet.h"

namespace bareskin::cli {
namespace fs = std::filesystem;

namespace {

Image to_image(const torch::Tensor& chw) {
  auto hwc = chw.detach().to(torch::kCPU, torch::kFloat).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image image(int(hwc.size(1)), int(hwc.size(0)), int(hwc.size(2)), ColorSpace::sRGB);
  std::memcpy(image.pixels.data(), hwc.data_ptr<float>(), image.pixels.size() * sizeof(float));
  return image;
}

void write_png(const std::string& path, const torch::Tensor& chw) { write_file_atomic(path, encode_png(to_image(chw))); }

bool is_photo(const fs::path& p) {
  std::string ext = p.extension().string();
  for (auto& c : ext) c = char(std::tolower(c));
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
}

// Every output of one photo, each written atomically into `dir` (made only once the photo has succeeded).
void write_result(const bsn::DemakeupResult& r, const bsn::Demakeup& d, const std::string& dir, const std::string& photo) {
  make_directories(dir);
  write_png(dir + "/aligned.png", r.aligned);
  write_png(dir + "/bare.png", r.bare);
  write_png(dir + "/unlit.png", r.unlit * r.mask);
  write_png(dir + "/uv.png", r.uv);
  write_png(dir + "/uv_mask.png", r.uv_mask);
  nlohmann::json j = recon::coefficients_to_json(r.coefficients.to(torch::kCPU), d.model->layout(true));
  nlohmann::json lm = nlohmann::json::array();
  for (int i = 0; i < 68; ++i) lm.push_back({r.landmarks(i, 0), r.landmarks(i, 1)});
  j["photo"] = photo;
  j["detector_score"] = r.score;
  j["photo_landmarks"] = lm;
  j["align"] = {{"similarity", {{r.similarity(0, 0), r.similarity(0, 1), r.similarity(0, 2)},
                                {r.similarity(1, 0), r.similarity(1, 1), r.similarity(1, 2)}}},
                {"source", "detector"}};
  j["camera"] = {{"focal", 1015.0 * 256 / 224}, {"cx", 128}, {"cy", 128}, {"width", 256}, {"height", 256}};
  write_file_atomic(dir + "/coefficients.json", j.dump(2) + "\n");
}

}  // namespace

std::function<void()> setup_demakeup_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string input, output, run, teacher, model, device = "cpu";
    int64_t uv_size = 1024;
    int detector_size = 416;
    bool keep_going = false;
  };
  auto o = std::make_shared<Options>();
  app.add_option("input", o->input, "A photo (PNG/JPEG/TIFF) or a folder of photos")->required();
  app.add_option("-o,--output", o->output, "Output folder (one subfolder per photo when the input is a folder)")->required();
  app.add_option("--run", o->run, "The 'bareskin train bareskin' run folder (G; names F and the model)")->required();
  app.add_option("--teacher", o->teacher, "The teacher F's run (default: the one the run was trained with)");
  app.add_option("--model", o->model, "The morphable model (default: the one the run was trained with)");
  app.add_option("--uv-size", o->uv_size, "Side of the UV map the bare skin is unwrapped into")->capture_default_str();
  app.add_option("--detector-size", o->detector_size, "Face detector input (multiple of 32)")->capture_default_str();
  app.add_option("--device", o->device, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.add_flag("--keep-going", o->keep_going, "With a folder: skip photos that fail and list them at the end");
  app.footer("Outputs: aligned.png (the 256² input G saw), bare.png (bare skin), unlit.png (the fit's albedo render), "
             "coefficients.json (F's fit: the coefficient file), uv.png + uv_mask.png (bare skin in the template UV).\n"
             "Example:\n  bareskin demakeup photo.jpg --run runs/bsn -o out/");
  return [o, &globals] {
    set_torch_threads(globals);
    if (o->device == "cuda" && !torch::cuda::is_available())
      throw InvalidInput("--device cuda", "no CUDA device is available", "use --device cpu");
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
    const torch::Device device = o->device == "cuda" ? torch::Device(torch::kCUDA) : torch::Device(torch::kCPU);
    const detect::PhotoDetector detector = photo_detector(globals, o->detector_size);
    if (!folder) {  // a photo without a face fails before the networks load
      Image image = read_image(photos[0].string());
      if (image.channels < 3) throw InvalidInput(photos[0].string(), "is not an RGB photo", "give a colour photo");
      if (detector(image).empty()) throw InvalidInput(photos[0].string(), "no face was found", "give a photo with a face of at least ~80 px");
    }
    const bsn::Demakeup d = bsn::Demakeup::load(o->run, o->teacher, o->model, device);
    std::vector<std::string> failed;
    auto bar = globals.progress("demakeup");
    for (size_t i = 0; i < photos.size(); ++i) {
      const std::string photo = photos[i].string();
      try {
        Image image = read_image(photo);
        if (image.channels < 3) throw InvalidInput(photo, "is not an RGB photo", "give a colour photo");
        const auto r = bsn::demakeup(d, image, detector, o->uv_size, photo);
        write_result(r, d, folder ? o->output + "/" + photos[i].stem().string() : o->output, photo);
      } catch (const Error& e) {
        if (!o->keep_going || !folder) throw;
        failed.push_back(e.what());
      }
      bar.update(int64_t(i + 1), int64_t(photos.size()), photos[i].filename().string());
    }
    bar.finish();
    for (const auto& f : failed) std::cerr << "skipped: " << f << "\n";
    if (!globals.quiet()) std::cerr << "wrote " << o->output << " (" << photos.size() - failed.size() << " of " << photos.size() << " photos)\n";
    if (!failed.empty()) throw InvalidInput(o->input, std::to_string(failed.size()) + " photo(s) failed (listed above)", "");
  };
}

}  // namespace bareskin::cli
