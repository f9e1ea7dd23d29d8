// bareskin recon: a photo → face-api's 68 landmarks → Deep3DFaceRecon's 5-point alignment (detect/align.h) → the net
// F or E of a `bareskin train recon` run → coefficient file, posed mesh (OBJ), overlay picture, landmarks, and a
// confidence; --refine continues with mm-fit's fitters (morphable/fit.h) from the net's answer. docs/cli.md.
#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <iostream>

#include "apps/cli.h"
#include "apps/detector.h"
#include "training/recon_eval.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "detect/align.h"
#include "detect/face_api.h"
#include "morphable/coefficients.h"
#include "morphable/fit.h"
#include "morphable/model.h"
#include "training/checkpoint.h"
#include "training/recon.h"

namespace bareskin::cli {
namespace {

namespace fs = std::filesystem;

torch::Tensor to_chw(const Image& img) {
  BS_CHECK(img.channels >= 3, "an RGB image");
  torch::Tensor t = torch::from_blob(const_cast<float*>(img.pixels.data()), {img.height, img.width, img.channels},
                                     torch::kFloat);
  return t.narrow(2, 0, 3).permute({2, 0, 1}).contiguous().clone();
}

Image to_image(const torch::Tensor& chw, ColorSpace space) {
  const torch::Tensor t = chw.detach().to(torch::kCPU, torch::kFloat).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image img(int(t.size(1)), int(t.size(0)), int(t.size(2)), space);
  std::memcpy(img.pixels.data(), t.data_ptr<float>(), img.pixels.size() * sizeof(float));
  return img;
}

Coefficients to_coefficients(const torch::Tensor& row, const recon::CoefficientLayout& l) {
  const nlohmann::json j = recon::coefficients_to_json(row, l);
  Coefficients c;
  const auto vec = [&](const char* k) {
    const std::vector<double> v = j.at(k).get<std::vector<double>>();
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size())).eval();
  };
  c.alpha = vec("alpha"), c.beta = vec("beta"), c.delta = vec("delta");
  c.rotation = vec("rotation"), c.translation = vec("translation");
  std::array<double, 27> g{};
  for (size_t k = 0; k < 27; ++k) g[k] = j.at("gamma")[k].get<double>();
  c.gamma = g;
  return c;
}

struct Context {
  recon::TrainedRecon net;
  MorphableModel geometry;  // for --refine and the OBJ
  std::shared_ptr<const detect::FaceApi> detector;
  recon::ConfidenceOptions confidence;
  bool refine = false;
  int refine_iterations = 30;
};

// Everything about one photo, computed before anything is written: a failure leaves no output.
void reconstruct_photo(const Context& ctx, const std::string& photo_path, const std::string& out_dir, bool quiet) {
  const Image photo = read_image(photo_path);
  if (photo.channels < 3) throw InvalidInput(photo_path, "is not an RGB image", "give a colour photo");
  const std::vector<detect::Face> faces = ctx.detector->detect(detect::photo_tensor(photo, photo_path));
  if (faces.empty()) throw InvalidInput(photo_path, "no face was found", "give a photo with a face of at least ~80 px");
  const detect::Landmarks68 detected = faces.front().points;
  // The 256² aligned frame scaled to the net's size.
  const int S = int(ctx.net.image_size);
  detect::Similarity sim = detect::alignment(detected);
  sim.scale *= S / double(detect::kAlignedSize);
  sim.translation *= S / double(detect::kAlignedSize);
  const Image aligned = detect::warp_aligned(photo, sim, S);
  const detect::Landmarks68 lm_aligned = detect::transform(sim, detected);
  torch::Tensor lm = torch::empty({68, 2}, torch::kDouble);
  for (int k = 0; k < 68; ++k) lm[k][0] = lm_aligned(k, 0), lm[k][1] = lm_aligned(k, 1);
  const recon::Reconstruction r = recon::reconstruct(ctx.net, to_chw(aligned), lm, ctx.confidence);
  const recon::CoefficientLayout layout = ctx.net.model.layout(true);
  Coefficients c = to_coefficients(r.coefficients, layout);
  nlohmann::json extra = {{"source", "bareskin recon"},
                          {"photo", photo_path},
                          {"net", ctx.net.module},
                          {"forward_ms", r.milliseconds},
                          {"confidence", r.confidence},
                          {"flagged", r.flagged},
                          {"landmark_residual_px", r.landmark_residual_px},
                          {"psnr_db", r.psnr_db},
                          {"detector_score", faces.front().score},
                          {"align", {{"similarity", {{sim.scale, 0, sim.translation.x()}, {0, sim.scale, sim.translation.y()}}},
                                     {"size", S},
                                     {"frame", "coefficients are seen by the canonical camera in the aligned frame"}}}};
  const Camera aligned_cam = recon::canonical_camera(S);
  if (ctx.refine) {
    const auto t0 = std::chrono::steady_clock::now();
    LandmarkFit start;
    start.alpha = c.alpha, start.beta = c.beta, start.rotation = c.rotation, start.translation = c.translation;
    LandmarkFitOptions lo;
    lo.shape_components = int(c.alpha.size());
    lo.expression_components = int(c.beta.size());
    lo.iterations = ctx.refine_iterations;
    lo.start = &start;
    const LandmarkFit fit = fit_landmarks(ctx.geometry, lm_aligned, aligned_cam, lo);
    c.alpha = fit.alpha, c.beta = fit.beta, c.rotation = fit.rotation, c.translation = fit.translation;
    Image linear = aligned;
    for (float& v : linear.pixels) v = srgb_to_linear(v);
    linear.color_space = ColorSpace::Linear;
    PhotometricFitOptions po;
    po.appearance_components = int(c.delta.size());
    const PhotometricFit pf = fit_photometric(ctx.geometry, posed_mesh(ctx.geometry, c), aligned_cam, linear, po);
    c.delta = pf.delta;
    c.gamma = pf.gamma;
    extra["refine"] = {{"landmark_rms_px", fit.rms_px}, {"landmark_iterations", fit.iterations},
                       {"psnr_db", pf.psnr_db},
                       {"ms", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()}};
  }
  c.extra = extra;
  // The overlay at the photo's size: the aligned frame's camera mapped back through the similarity.
  Camera photo_cam = aligned_cam;
  photo_cam.width = photo.width;
  photo_cam.height = photo.height;
  photo_cam.focal = aligned_cam.focal / sim.scale;
  photo_cam.cx = (aligned_cam.cx - sim.translation.x()) / sim.scale;
  photo_cam.cy = (aligned_cam.cy - sim.translation.y()) / sim.scale;
  torch::Tensor row;
  {
    const nlohmann::json cj = {{"alpha", std::vector<double>(c.alpha.data(), c.alpha.data() + c.alpha.size())},
                               {"beta", std::vector<double>(c.beta.data(), c.beta.data() + c.beta.size())},
                               {"delta", std::vector<double>(c.delta.data(), c.delta.data() + c.delta.size())},
                               {"rotation", {c.rotation.x(), c.rotation.y(), c.rotation.z()}},
                               {"translation", {c.translation.x(), c.translation.y(), c.translation.z()}},
                               {"gamma", *c.gamma}};
    row = recon::coefficients_from_json(cj, layout).unsqueeze(0).to(ctx.net.device);
  }
  const recon::FaceRender f = ctx.net.model.render(row, photo_cam);
  const torch::Tensor photo_t = to_chw(photo).unsqueeze(0).to(ctx.net.device);
  const torch::Tensor over = recon::linear_to_srgb(f.colour.clamp(0, 1)) * f.mask + photo_t * (1 - f.mask);
  Landmarks out_lm;
  out_lm.units = "px";
  out_lm.points = Eigen::MatrixXd(68, 2);
  const torch::Tensor plm = f.landmarks[0].to(torch::kCPU, torch::kDouble).contiguous();
  for (int k = 0; k < 68; ++k) out_lm.points(k, 0) = plm[k][0].item<double>(), out_lm.points(k, 1) = plm[k][1].item<double>();
  const Mesh mesh = posed_mesh(ctx.geometry, c);
  // Written only now, each file atomically.
  fs::create_directories(out_dir);
  write_coefficients(out_dir + "/coefficients.json", c);
  write_mesh(out_dir + "/mesh.obj", mesh);
  write_image(out_dir + "/overlay.png", to_image(over[0], ColorSpace::sRGB));
  write_image(out_dir + "/aligned.png", aligned);
  write_landmarks(out_dir + "/landmarks.json", out_lm);
  if (!quiet) {
    std::cerr << photo_path << ": confidence " << r.confidence << (r.flagged ? " (FLAGGED)" : "") << ", landmarks "
              << r.landmark_residual_px << " px, PSNR " << r.psnr_db << " dB → " << out_dir << "\n";
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
  app.add_option("--refine-iterations", o->refine_iterations, "Landmark-fit iterations of --refine")->capture_default_str();
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
  app.add_option("--device", o->device, "cpu or cuda")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.footer("Outputs: coefficients.json (the coefficient file, with confidence), mesh.obj, overlay.png, aligned.png,\n"
             "landmarks.json. Example:\n  bareskin recon photo.jpg --run runs/F -o out/\n");
  return [o, &globals] {
    set_torch_threads(globals);
    if (o->device == "cuda" && !torch::cuda::is_available()) {
      throw InvalidInput("--device cuda", "no CUDA device is available", "use --device cpu");
    }
    const torch::Device device = o->device == "cuda" ? torch::Device(torch::kCUDA) : torch::Device(torch::kCPU);
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
      if (model_path.empty()) throw InvalidInput(o->run, "names no model file", "give --model");
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
    ctx.confidence = o->confidence;
    ctx.refine = o->refine;
    ctx.refine_iterations = o->refine_iterations;
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
