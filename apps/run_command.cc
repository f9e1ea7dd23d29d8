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
    std::string photo, output, model, texture, bareskin, teacher, device = "cpu", weights, landmarks, face_mask,
        sr_maps = "diffuse,roughness,specular";
    std::vector<std::string> upscale;
    bool no_bareskin = false, no_upscale = false;
    texture::AvatarOptions avatar;
  };
  auto opt = std::make_shared<Options>();
  app.add_option("photo", opt->photo, "Face photo (PNG/JPEG); the best face found is used")->required();
  app.add_option("-o,--output", opt->output, "Avatar folder (written atomically: all or nothing)")->required();
  app.add_option("--model", opt->model, "Morphable model (model.safetensors)")->required();
  app.add_option("--texture", opt->texture, "pix2pixHD run (bareskin train texture)")->required();
  app.add_option("--upscale", opt->upscale, "SRGAN runs (bareskin train upscale), one per map; maps without one are "
                                            "upscaled bicubically")
      ->expected(0, -1);
  app.add_option("--bareskin", opt->bareskin, "BareSkinNet run (bareskin train bareskin): G before reconstruction "
                                              "(this or --no-bareskin is required)");
  app.add_option("--teacher", opt->teacher, "Reconstruction net F (bareskin train recon run): the 3DMM coefficients "
                                            "from G's image; without it mm-fit's landmark and photometric fits");
  app.add_option("--sr-maps", opt->sr_maps,
                 "Maps SRGAN upscales where an --upscale run is given for them (comma-separated; the others "
                 "bicubically: SRGAN gained nothing over bicubic on the smooth normal map, docs/texture.md)")
      ->capture_default_str();
  app.add_flag("--no-bareskin", opt->no_bareskin, "Skip G: the photo itself is reconstructed and unwrapped (this or "
                                                  "--bareskin is required)");
  app.add_flag("--no-upscale", opt->no_upscale, "Maps at the texture net's size only");
  app.add_option("--input-res", opt->avatar.input_res, "UV size of the unwrap (0: the texture run's size)")
      ->capture_default_str()->check(CLI::Validator(
          [](std::string& text) {
            const int v = std::atoi(text.c_str());
            return v == 0 || (v >= 64 && v <= 8192) ? std::string() : std::string("must be 0 or lie in [64, 8192]");
          },
          "0 or 64..8192"));
  app.add_option("--preview-size", opt->avatar.preview_size, "Relit previews' size")->capture_default_str()
      ->check(CLI::Range(16, 4096));
  add_device_option(app, opt->device);
  app.add_option("--landmarks", opt->landmarks,
                 "The photo's 68 landmarks (a landmark file, px): used instead of the detector (e.g. for aligned shards)");
  app.add_option("--weights", opt->weights, "face-api's tfjs models (default: face_api/ in the assets)");
  app.add_option("--face-mask", opt->face_mask,
                 "The photo's face segmentation (grey PNG at the photo's size, white = face skin, eyes, brows, lips; "
                 "black = hair, glasses, hands, background): unwrap texels touching black are left to the texture net");
  app.footer("Example: bareskin run photo.png -o avatar/ --model model.safetensors --texture runs/tex "
             "--upscale runs/up_diffuse --bareskin runs/bsn --teacher runs/F\nExit 3 (nothing written) for a photo without a face "
             "or runs that do not fit each other or the model.");
  return [opt, &globals] {
    set_torch_threads(globals);
    opt->device = parse_device(opt->device).str();
    keep_freed_memory();
    if (opt->no_bareskin == !opt->bareskin.empty())
      throw CLI::ValidationError("run", "give exactly one of --bareskin RUN and --no-bareskin");
    std::vector<std::string> inputs = {opt->photo,     opt->model,   opt->texture,  opt->bareskin,
                                       opt->teacher,   opt->landmarks, opt->weights, opt->face_mask};
    inputs.insert(inputs.end(), opt->upscale.begin(), opt->upscale.end());
    check_output_apart(opt->output, inputs);
    opt->avatar.sr_maps = texture::parse_map_list(opt->sr_maps, "--sr-maps");
    const Image photo = read_image(opt->photo);
    detect::check_photo(photo, opt->photo);  // before the nets load
    const Image face_mask = opt->face_mask.empty() ? Image() : texture::read_face_mask(opt->face_mask, photo);
    const auto t0 = std::chrono::steady_clock::now();
    nlohmann::json load;  // wall seconds per part of the loading
    auto lap = [&load, t = t0](const char* part) mutable {
      const auto now = std::chrono::steady_clock::now();
      load[part] = std::chrono::duration<double>(now - t).count();
      t = now;
    };
    const MorphableModel model = read_model(opt->model);
    lap("model");
    const auto nets = texture::load_avatar_nets(opt->model, opt->texture, opt->upscale, opt->device, opt->teacher);
    lap("nets");
    const texture::Demakeup G = opt->no_bareskin ? texture::Demakeup{} : texture::load_demakeup(opt->bareskin, opt->device);
    lap("bareskin");
    texture::FaceFinder detector;
    if (!opt->landmarks.empty()) {
      const detect::Landmarks68 points = read_image_landmarks(opt->landmarks, photo.width, photo.height).points;
      detector = [points](const Image&) { return std::vector<detect::Landmarks68>{points}; };
    } else {
      auto face_api = std::make_shared<detect::FaceApi>(opt->weights.empty() ? detect::default_face_api_folder()
                                                                               : opt->weights);
      detector = [face_api](const Image& srgb) {
        std::vector<detect::Landmarks68> faces;
        for (const detect::Face& f : face_api->detect(detect::photo_tensor(srgb, "photo"), {}))
          faces.push_back(f.points);
        return faces;
      };
    }
    lap("photo_detector");
    const double load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    opt->avatar.upscale = !opt->no_upscale;
    const auto t1 = std::chrono::steady_clock::now();
    const texture::Avatar avatar = texture::avatar_from_photo(photo, opt->photo, detector, model, nets, G, opt->avatar,
                                                                  face_mask);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
    texture::write_avatar(opt->output, avatar,
                          {{"photo", opt->photo}, {"model", opt->model}, {"texture", opt->texture},
                           {"upscale", opt->upscale}, {"bareskin", opt->no_bareskin ? "" : opt->bareskin},
                           {"teacher", opt->teacher}, {"face_mask", opt->face_mask},
                           {"sr_maps", opt->sr_maps}, {"device", opt->device}, {"load_seconds", load_seconds},
                           {"load_seconds_by_part", load}, {"pipeline_seconds", seconds}},
                          std::max(1, globals.threads > 0 ? globals.threads : int(std::thread::hardware_concurrency())));
    if (!globals.quiet())
      std::cerr << "wrote " << opt->output << " (" << fmt::format("{:.1f}", seconds) << " s; upscaled with "
                << (avatar.upscaled_with.empty() ? "none" : avatar.upscaled_with) << ")\n";
  };
}

}  // namespace bareskin::cli
