// bareskin recon: a photo → face-api's 68 landmarks → recon/recon_photo.h (Deep3DFaceRecon's 5-point alignment, the
// net F or E of a `bareskin train recon` run, --refine: mm-fit's fitters from the net's answer) → coefficient file,
// posed mesh (OBJ), overlay picture, landmarks, and a confidence. This file parses flags and writes files. docs/cli.md.
#include <algorithm>
#include <filesystem>
#include <iostream>

#include "apps/cli.h"
#include "apps/device_flag.h"
#include "apps/detector.h"
#include "training/device.h"
#include "recon/recon_eval.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "detect/face_api.h"
#include "morphable/coefficients.h"
#include "morphable/model.h"
#include "training/checkpoint.h"
#include "recon/recon.h"
#include "recon/recon_photo.h"

namespace bareskin::cli {
namespace {

namespace fs = std::filesystem;

struct Context {
  recon::TrainedRecon net;
  MorphableModel geometry;  // for --refine and the OBJ
  std::shared_ptr<const detect::FaceApi> detector;
  recon::PhotoReconOptions options;
};

// Everything about one photo, computed before anything is written: a failure leaves no output.
void reconstruct_photo(const Context& ctx, const std::string& photo_path, const std::string& out_dir, bool quiet) {
  const Image photo = read_image(photo_path);
  if (photo.channels < 3) throw InvalidInput(photo_path, "is not an RGB image", "give a colour photo");
  const std::vector<detect::Face> faces = ctx.detector->detect(detect::photo_tensor(photo, photo_path));
  if (faces.empty()) throw InvalidInput(photo_path, "no face was found", "give a photo with a face of at least ~80 px");
  recon::PhotoReconstruction r = recon::reconstruct_photo(ctx.net, ctx.geometry, photo, faces.front().points, ctx.options);
  Coefficients& c = r.coefficients;
  c.extra.update({{"source", "bareskin recon"}, {"photo", photo_path}, {"detector_score", faces.front().score}});
  const auto [overlay, projected] = recon::photo_overlay(ctx.net, c, r.similarity, photo);
  Landmarks out_lm;
  out_lm.units = "px";
  out_lm.points = projected;
  const Mesh mesh = posed_mesh(ctx.geometry, c);
  // Written only now, each file atomically.
  fs::create_directories(out_dir);
  write_coefficients(out_dir + "/coefficients.json", c);
  write_mesh(out_dir + "/mesh.obj", mesh);
  write_image(out_dir + "/overlay.png", overlay);
  write_image(out_dir + "/aligned.png", r.aligned);
  write_landmarks(out_dir + "/landmarks.json", out_lm);
  if (!quiet) {
    std::cerr << photo_path << ": confidence " << r.answer.confidence << (r.answer.flagged ? " (FLAGGED)" : "")
              << ", landmarks " << r.answer.landmark_residual_px << " px, PSNR " << r.answer.psnr_db << " dB → "
              << out_dir << "\n";
  }
}

bool is_image(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& ch : e) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" || e == ".tiff";
}

}  // namespace

std::function<void()> setup_recon_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string input, output, run, model, device = "cpu";
    bool refine = false, keep_going = false;
    int refine_iterations = 30;
    recon::ConfidenceOptions confidence;
    recon::EvalOptions eval;
  };
  auto o = std::make_shared<Options>();
  app.add_option("photo", o->input, "A photo (PNG, JPEG, TIFF) or a folder of photos");
  app.add_option("-o,--output", o->output, "Output folder (per photo a subfolder when the input is a folder)")->required();
  app.add_option("--run", o->run, "The net: a 'bareskin train recon' run folder or its checkpoint")->required();
  app.add_option("--model", o->model, "The morphable model (default: the one the run was trained with)");
  app.add_flag("--refine", o->refine, "Continue with mm-fit's fitters from the net's answer (landmarks, then appearance "
                                      "and light)");
  app.add_option("--refine-iterations", o->refine_iterations, "Landmark-fit iterations of --refine")->capture_default_str()
      ->check(CLI::Range(1, 1000));
  app.add_flag("--keep-going", o->keep_going, "With a folder: report a photo that fails and go on (exit 3 at the end)");
  app.add_option("--flag-landmark-px", o->confidence.landmark_px, "Flag answers whose landmarks are further than this "
                                                                  "from the detector's (px, 256² frame)")->capture_default_str();
  app.add_option("--flag-psnr", o->confidence.psnr_db, "Flag answers whose render matches the photo worse than this "
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
    if (o->eval.data.empty() && !fs::exists(o->input)) {
      throw IoError(o->input, "does not exist", "give a photo or a folder of photos");
    }
    std::string model_path = o->model;
    if (model_path.empty()) {
      // The run's config names the model it was trained with.
      const std::string ckpt = fs::is_directory(o->run) ? train::checkpoint_path(o->run) : o->run;
      if (!fs::exists(ckpt)) throw IoError(ckpt, "does not exist", "give --run the folder of 'bareskin train recon'");
      const std::string cfg = (fs::path(ckpt).parent_path() / "config.json").string();
      if (fs::exists(cfg)) model_path = nlohmann::json::parse(read_file(cfg), nullptr, false).value("model", "");
      if (model_path.empty()) {
        throw InvalidInput(cfg, "is missing or names no model file (the one the run was trained with)",
                           "give --run the folder of 'bareskin train recon', or --model");
      }
    }
    if (!o->eval.data.empty()) {
      recon::EvalOptions e = o->eval;
      e.run = o->run;
      e.model = model_path;
      e.output = o->output;
      e.confidence = o->confidence;
      auto bar = globals.progress("recon eval");
      const nlohmann::json summary = recon::evaluate_recon(e, bar.callback());
      bar.finish();
      if (!globals.quiet()) std::cout << summary.dump(2) << "\n";
      return;
    }
    Context ctx;
    ctx.net = recon::load_recon(o->run, recon::FaceModel::load(model_path), device);
    ctx.geometry = read_model(model_path);
    ctx.detector = std::make_shared<const detect::FaceApi>(detect::default_face_api_folder());
    ctx.options.confidence = o->confidence;
    ctx.options.refine = o->refine;
    ctx.options.refine_iterations = o->refine_iterations;
    if (!fs::is_directory(o->input)) {
      reconstruct_photo(ctx, o->input, o->output, globals.quiet());
      return;
    }
    std::vector<fs::path> photos;
    for (const auto& e : fs::directory_iterator(o->input)) {
      if (e.is_regular_file() && is_image(e.path())) photos.push_back(e.path());
    }
    std::sort(photos.begin(), photos.end());
    if (photos.empty()) throw InvalidInput(o->input, "holds no photos (.png, .jpg, .tif)", "give a folder of photos");
    int failed = 0;
    for (const fs::path& p : photos) {
      try {
        reconstruct_photo(ctx, p.string(), (fs::path(o->output) / p.stem()).string(), globals.quiet());
      } catch (const Error& e) {
        if (!o->keep_going) throw;
        ++failed;
        std::cerr << "error: " << e.what() << "\n";
      }
    }
    if (failed) {
      throw InvalidInput(o->input, std::to_string(failed) + " of " + std::to_string(photos.size()) + " photos failed",
                         "see the lines above");
    }
  };
}

}  // namespace bareskin::cli
