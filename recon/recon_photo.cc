#include "recon/recon_photo.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "detect/align.h"
#include "detect/face_api.h"
#include "morphable/fit.h"
#include "training/checkpoint.h"

namespace bareskin::recon {
namespace {

torch::Tensor to_chw(const Image& img) {
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

std::vector<double> values(const Eigen::VectorXd& v) { return {v.data(), v.data() + v.size()}; }

// mm-fit's landmark fit from the net's pose and shape, then its photometric fit (δ, γ) on the aligned image.
nlohmann::json refine(Coefficients& c, const MorphableModel& geometry, const Image& aligned,
                      const detect::Landmarks68& landmarks, int iterations) {
  const auto t0 = std::chrono::steady_clock::now();
  const Camera camera = canonical_camera(aligned.width);
  LandmarkFit start;
  start.alpha = c.alpha, start.beta = c.beta, start.rotation = c.rotation, start.translation = c.translation;
  LandmarkFitOptions lo;
  lo.shape_components = int(c.alpha.size());
  lo.expression_components = int(c.beta.size());
  lo.iterations = iterations;
  lo.start = &start;
  const LandmarkFit fit = fit_landmarks(geometry, Eigen::MatrixX2d(landmarks), camera, lo);
  c.alpha = fit.alpha, c.beta = fit.beta, c.rotation = fit.rotation, c.translation = fit.translation;
  Image linear = aligned;
  for (float& v : linear.pixels) v = bareskin::srgb_to_linear(v);
  linear.color_space = ColorSpace::Linear;
  PhotometricFitOptions po;
  po.appearance_components = int(c.delta.size());
  const PhotometricFit pf = fit_photometric(geometry, posed_mesh(geometry, c), camera, linear, po);
  c.delta = pf.delta;
  c.gamma = pf.gamma;
  return {{"landmark_rms_px", fit.rms_px},
          {"landmark_iterations", fit.iterations},
          {"psnr_db", pf.psnr_db},
          {"ms", std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count()}};
}

// The net on a face aligned at its own size.
PhotoReconstruction at_net_size(const TrainedRecon& net, const MorphableModel& geometry, Image aligned,
                                const detect::Landmarks68& landmarks, const detect::Similarity& similarity,
                                const PhotoReconOptions& options) {
  options.check();
  PhotoReconstruction out;
  torch::Tensor lm = torch::empty({68, 2}, torch::kDouble);
  for (int k = 0; k < 68; ++k) lm[k][0] = landmarks(k, 0), lm[k][1] = landmarks(k, 1);
  out.answer = reconstruct(net, to_chw(aligned), lm, options.confidence);
  Coefficients& c = out.coefficients;
  c = to_coefficients(out.answer.coefficients, net.model.layout(true));
  const int S = int(net.image_size);
  nlohmann::json extra = {
      {"net", net.module},
      {"forward_ms", out.answer.milliseconds},
      {"confidence", out.answer.confidence},
      {"flagged", out.answer.flagged},
      {"landmark_residual_px", out.answer.landmark_residual_px},
      {"psnr_db", out.answer.psnr_db},
      {"align",
       {{"similarity", {{similarity.scale, 0, similarity.translation.x()}, {0, similarity.scale, similarity.translation.y()}}},
        {"size", S},
        {"frame", "coefficients are seen by the canonical camera in the aligned frame"}}}};
  if (options.refine) extra["refine"] = refine(c, geometry, aligned, landmarks, options.refine_iterations);
  c.extra = extra;
  out.similarity = similarity;
  out.aligned = std::move(aligned);
  out.landmarks = landmarks;
  return out;
}

}  // namespace

Coefficients to_coefficients(const torch::Tensor& row, const CoefficientLayout& layout) {
  const nlohmann::json j = coefficients_to_json(row, layout);
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

torch::Tensor coefficients_row(const Coefficients& c, const CoefficientLayout& layout) {
  nlohmann::json j = {{"alpha", values(c.alpha)},
                      {"beta", values(c.beta)},
                      {"delta", values(c.delta)},
                      {"rotation", {c.rotation.x(), c.rotation.y(), c.rotation.z()}},
                      {"translation", {c.translation.x(), c.translation.y(), c.translation.z()}}};
  if (c.gamma) j["gamma"] = *c.gamma;
  return coefficients_from_json(j, layout);
}

PhotoReconstruction reconstruct_aligned(const TrainedRecon& net, const MorphableModel& geometry, const Image& aligned,
                                        const detect::Landmarks68& landmarks, const PhotoReconOptions& options) {
  if (aligned.width != aligned.height || aligned.channels < 3)
    throw InvalidInput("aligned face", "is " + std::to_string(aligned.width) + "×" + std::to_string(aligned.height) +
                                           " with " + std::to_string(aligned.channels) + " channels",
                       "give a square RGB face aligned with detect/align.h");
  const int S = int(net.image_size);
  const double k = S / double(aligned.width);
  detect::Similarity scaled;
  scaled.scale = k;
  if (aligned.width == S) return at_net_size(net, geometry, aligned, landmarks, scaled, options);
  namespace F = torch::nn::functional;
  const torch::Tensor x = F::interpolate(to_chw(aligned).unsqueeze(0),
                                         F::InterpolateFuncOptions().size(std::vector<int64_t>{S, S}).mode(torch::kArea));
  return at_net_size(net, geometry, to_image(x[0], ColorSpace::sRGB), landmarks * k, scaled, options);
}

PhotoReconstruction reconstruct_photo(const TrainedRecon& net, const MorphableModel& geometry, const Image& photo,
                                      const detect::Landmarks68& detected, const PhotoReconOptions& options) {
  if (photo.channels < 3) throw InvalidInput("photo", "is not an RGB image", "give a colour photo");
  // The 256² aligned frame scaled to the net's size.
  const int S = int(net.image_size);
  detect::Similarity sim = detect::alignment(detected);
  sim.scale *= S / double(detect::kAlignedSize);
  sim.translation *= S / double(detect::kAlignedSize);
  return at_net_size(net, geometry, detect::warp_aligned(photo, sim, S), detect::transform(sim, detected), sim,
                     options);
}

std::pair<Image, detect::Landmarks68> photo_overlay(const TrainedRecon& net, const Coefficients& c,
                                                    const detect::Similarity& sim, const Image& photo) {
  torch::NoGradGuard no_grad;
  const Camera aligned_cam = canonical_camera(int(net.image_size));
  Camera photo_cam = aligned_cam;
  photo_cam.width = photo.width;
  photo_cam.height = photo.height;
  photo_cam.focal = aligned_cam.focal / sim.scale;
  photo_cam.cx = (aligned_cam.cx - sim.translation.x()) / sim.scale;
  photo_cam.cy = (aligned_cam.cy - sim.translation.y()) / sim.scale;
  const torch::Tensor row = coefficients_row(c, net.model.layout(true)).unsqueeze(0).to(net.device);
  const FaceRender f = net.model.render(row, photo_cam);
  const torch::Tensor photo_t = to_chw(photo).unsqueeze(0).to(net.device);
  const torch::Tensor over = linear_to_srgb(f.colour.clamp(0, 1)) * f.mask + photo_t * (1 - f.mask);
  detect::Landmarks68 lm;
  const torch::Tensor plm = f.landmarks[0].to(torch::kCPU, torch::kDouble).contiguous();
  for (int k = 0; k < 68; ++k) lm(k, 0) = plm[k][0].item<double>(), lm(k, 1) = plm[k][1].item<double>();
  return {to_image(over[0], ColorSpace::sRGB), lm};
}

namespace {

struct PhotoContext {
  TrainedRecon net;
  MorphableModel geometry;  // for the refinement and the OBJ
  std::shared_ptr<const detect::FaceApi> detector;
  PhotoReconOptions options;
};

// Everything about one photo, computed before anything is written: a failure leaves no output.
void reconstruct_photo_file(const PhotoContext& ctx, const std::string& photo_path, const std::string& out_dir,
                            bool quiet) {
  const Image photo = read_image(photo_path);
  detect::check_photo(photo, photo_path);
  const std::vector<detect::Face> faces = ctx.detector->detect(detect::photo_tensor(photo, photo_path));
  if (faces.empty()) throw InvalidInput(photo_path, "no face was found", "give a photo with a face of at least ~80 px");
  PhotoReconstruction r = reconstruct_photo(ctx.net, ctx.geometry, photo, faces.front().points, ctx.options);
  Coefficients& c = r.coefficients;
  c.extra.update({{"source", "bareskin recon"}, {"photo", photo_path}, {"detector_score", faces.front().score}});
  const auto [overlay, projected] = photo_overlay(ctx.net, c, r.similarity, photo);
  Landmarks out_lm;
  out_lm.units = "px";
  out_lm.points = projected;
  const Mesh mesh = posed_mesh(ctx.geometry, c);
  // Written only now, each file atomically.
  std::filesystem::create_directories(out_dir);
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

bool is_image(const std::filesystem::path& p) {
  std::string e = p.extension().string();
  for (char& ch : e) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" || e == ".tiff";
}

}  // namespace

void PhotoReconOptions::check() const {
  confidence.check();
  if (refine_iterations < 1 || refine_iterations > 1000)
    throw InvalidInput("--refine-iterations", std::to_string(refine_iterations) + " is outside [1, 1000]",
                       "e.g. --refine-iterations 30");
}

void PhotoFilesOptions::check() const {
  if (input.empty()) throw InvalidInput("recon", "names no photo", "give a photo or a folder of photos");
  if (output.empty()) throw InvalidInput("-o", "names no output folder", "give the output folder");
  if (run.empty()) throw InvalidInput("--run", "is missing", "give the folder of 'bareskin train recon'");
  recon.check();
}

void reconstruct_photo_files(const PhotoFilesOptions& o) {
  namespace fs = std::filesystem;
  o.check();
  if (!fs::exists(o.input)) throw IoError(o.input, "does not exist", "give a photo or a folder of photos");
  // A thumbnail is refused before the run is looked for and the nets load.
  if (!fs::is_directory(o.input)) detect::check_photo(read_image(o.input), o.input);
  const std::string model = run_model_path(o.run, o.model);
  PhotoContext ctx;
  ctx.net = load_recon(o.run, FaceModel::load(model), o.device);
  ctx.geometry = read_model(model);
  ctx.detector = std::make_shared<const detect::FaceApi>(detect::default_face_api_folder());
  ctx.options = o.recon;
  if (!fs::is_directory(o.input)) {
    reconstruct_photo_file(ctx, o.input, o.output, o.quiet);
    return;
  }
  std::vector<fs::path> photos;
  for (const auto& e : fs::directory_iterator(o.input)) {
    if (e.is_regular_file() && is_image(e.path())) photos.push_back(e.path());
  }
  std::sort(photos.begin(), photos.end());
  if (photos.empty()) throw InvalidInput(o.input, "holds no photos (.png, .jpg, .tif)", "give a folder of photos");
  int failed = 0;
  for (const fs::path& p : photos) {
    try {
      reconstruct_photo_file(ctx, p.string(), (fs::path(o.output) / p.stem()).string(), o.quiet);
    } catch (const Error& e) {
      if (!o.keep_going) throw;
      ++failed;
      std::cerr << "error: " << e.what() << "\n";
    }
  }
  if (failed) {
    throw InvalidInput(o.input, std::to_string(failed) + " of " + std::to_string(photos.size()) + " photos failed",
                       "see the lines above");
  }
}

}  // namespace bareskin::recon
