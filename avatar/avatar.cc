#include "avatar/avatar.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <thread>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/log.h"
#include "core/mesh_io.h"
#include "core/png.h"
#include "core/svg_chart.h"
#include "render/camera.h"
#include "render/shade.h"
#include "core/shards.h"
#include "texgen/texture_sample.h"
#include "avatar/glb.h"
#include "detect/face_api.h"
#include "bareskinnet/bareskinnet.h"
#include "render/light_files.h"
#include "training/checkpoint.h"
#include "training/data.h"
#include "training/ssim.h"
#include "uvtools/unwarp.h"

namespace bareskin::texture {
namespace {

// The first channel of an image (a mask given as grey, grey + alpha or RGB), in [0, 1] as stored.
Image first_channel(const Image& image) {
  Image out(image.width, image.height, 1, ColorSpace::Data);
  for (size_t i = 0; i < out.pixels.size(); ++i) out.pixels[i] = image.pixels[i * size_t(image.channels)];
  return out;
}

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
double cpu_now() { return double(std::clock()) / CLOCKS_PER_SEC; }  // the process's CPU time, all threads

// Wall and CPU seconds of one stage into the avatar's tables (CPU time reads true on a shared machine).
struct StageTimer {
  Avatar& a;
  Clock::time_point wall = Clock::now();
  double cpu = cpu_now();
  void stop(const std::string& stage) {
    a.seconds[stage] = since(wall);
    a.cpu_seconds[stage] = cpu_now() - cpu;
    wall = Clock::now();
    cpu = cpu_now();
  }
};

constexpr uint64_t kPreviewLightSeed = 2022;  // preview lights: texgen's lights 0–2 of this seed

Image rgb_only(const Image& image) {
  if (image.channels == 3) return image;
  Image out(image.width, image.height, 3, image.color_space);
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = image.at(x, y, std::min(c, image.channels - 1));
  return out;
}

Image as_srgb(const Image& image) {
  Image out = rgb_only(image);
  if (out.color_space == ColorSpace::Linear) return to_srgb(out);
  out.color_space = ColorSpace::sRGB;
  return out;
}

}  // namespace

Image tensor_image(const torch::Tensor& t, ColorSpace space) {
  auto chw = (t.dim() == 4 ? t[0] : t).detach().to(torch::kCPU, torch::kFloat32);
  Image image(int(chw.size(2)), int(chw.size(1)), int(chw.size(0)), space);
  // Straight into the image's pixels (one pass over a 4K map, not a transposed copy and then a memcpy).
  torch::from_blob(image.pixels.data(), {chw.size(1), chw.size(2), chw.size(0)}, torch::kFloat32)
      .copy_(chw.permute({1, 2, 0}));
  return image;
}

torch::Tensor image_tensor(const Image& image) {
  return torch::from_blob(const_cast<float*>(image.pixels.data()), {1, image.height, image.width, image.channels},
                          torch::kFloat32)
      .permute({0, 3, 1, 2})
      .clone(torch::MemoryFormat::Contiguous);
}

Demakeup load_demakeup(const std::string& run, const std::string& device) {
  std::string path = run;
  if (std::filesystem::is_directory(run)) {
    path = train::checkpoint_path(run);
    for (const char* stage : {"stage2", "stage1"})
      if (std::filesystem::exists(train::checkpoint_path(run + "/" + stage))) {
        path = train::checkpoint_path(run + "/" + stage);
        break;
      }
  }
  auto [file, meta] = checkpoint_config(path);
  if (meta.value("task", "") != bsn::kTaskName)
    throw InvalidInput(file, "is a '" + meta.value("task", std::string("?")) + "' checkpoint, not BareSkinNet's",
                       "give the run of 'bareskin train bareskin' as --bareskin, or --no-bareskin");
  // G alone (its weights and options); the teacher, student, discriminator and LPIPS trunk are not built.
  auto d = std::make_shared<bsn::Demakeup>(bsn::load_generator(file, torch::Device(device)));
  return [d](const Image& aligned) {
    auto y = bsn::run_generator(*d, image_tensor(aligned).slice(1, 0, 3));
    return tensor_image(y, ColorSpace::sRGB);
  };
}

Coefficients fit_coefficients(const Image& bare, const detect::Landmarks68& landmarks, const MorphableModel& model,
                              const recon::TrainedRecon* F, const AvatarOptions& options) {
  Coefficients c;
  std::string from = "F";
  if (F) {
    c = recon::reconstruct_aligned(*F, model, bare, landmarks).coefficients;
  } else {
    const Camera camera = view_camera("front", detect::kAlignedSize, Eigen::Vector3d::Zero(), 1000);
    const LandmarkFit lm = fit_landmarks(model, Eigen::MatrixX2d(landmarks), camera, options.landmark_fit);
    c = to_coefficients(lm);
    const PhotometricFit photo = fit_photometric(model, posed_mesh(model, c), camera, to_linear(bare),
                                                 options.photometric);
    c.delta = photo.delta;
    c.gamma = photo.gamma;
    c.extra = {{"landmark_rms_px", lm.rms_px}, {"photometric_psnr_db", photo.psnr_db}};
    from = "mm-fit";
  }
  c.extra["camera"] = "front 256 1000";
  c.extra["coefficients_from"] = from;
  return c;
}

std::map<std::string, torch::Tensor> TextureInputs::tensors() const {
  return {{"unwrap", image_tensor(unwrap)},
          {"confidence", image_tensor(confidence)},
          {"mm_albedo", image_tensor(to_srgb(mm.albedo))},
          {"mm_normal", image_tensor(mm.normal)},
          {"mm_position", image_tensor(mm.position)}};
}

TextureInputs texture_inputs(const Image& bare, const Coefficients& c, const MorphableModel& model, int res,
                             const Image& face_mask) {
  if (!face_mask.empty() && (face_mask.width != bare.width || face_mask.height != bare.height))
    throw InvalidInput("face mask", "is not the aligned face's size (256²)", "give the mask of the same photo");
  const Camera camera = view_camera("front", detect::kAlignedSize, Eigen::Vector3d::Zero(), 1000);
  UnwarpOptions uo;
  uo.size = res;
  const Image inside = face_mask.empty() ? Image() : first_channel(face_mask);
  if (!inside.empty()) uo.inside = &inside;
  const UnwarpResult uw = unwarp(as_srgb(bare), posed_mesh(model, c), camera, uo);
  return {to_srgb(uw.colour), uw.confidence, texgen::model_uv_maps(model, c, res)};
}

Avatar avatar_from_aligned(const Image& aligned_in, const detect::Landmarks68& landmarks, const MorphableModel& model,
                           const AvatarNets& nets, const Demakeup& G, const AvatarOptions& options,
                           const Image& face_mask) {
  options.check();
  const TextureNet& net = nets.texture;
  const std::map<std::string, Upscaler>& upscalers = nets.upscalers;
  Avatar a;
  a.aligned = as_srgb(aligned_in);
  if (a.aligned.width != detect::kAlignedSize || a.aligned.height != detect::kAlignedSize)
    throw InvalidInput("aligned face", "is not 256²", "align photos with detect/align.h first");
  a.landmarks = landmarks;
  StageTimer t{a};
  a.bare = G ? as_srgb(G(a.aligned)) : a.aligned;
  t.stop("bareskin");

  Coefficients& c = a.coefficients;
  c = fit_coefficients(a.bare, landmarks, model, nets.F.get(), options);
  a.coefficients_from = c.extra.at("coefficients_from").get<std::string>();
  const Camera camera = view_camera("front", detect::kAlignedSize, Eigen::Vector3d::Zero(), 1000);
  const Mesh posed = posed_mesh(model, c);
  {
    const Image albedo = appearance_image(model, c);
    ShadeOptions so;
    so.texture = albedo.empty() ? nullptr : &albedo;
    so.gamma = *c.gamma;
    so.cull_back_faces = true;
    const Frame frame = render_frame(posed, camera, so);
    a.fit = a.aligned;
    const Image lit = to_srgb(frame.colour);
    for (int y = 0; y < a.fit.height; ++y)
      for (int x = 0; x < a.fit.width; ++x)
        if (frame.mask.at(x, y) > 0.5f)
          for (int k = 0; k < 3; ++k) a.fit.at(x, y, k) = lit.at(x, y, k);
  }
  a.mesh = model.topology;
  a.mesh.V = model.shape(c.alpha, c.beta);
  a.mesh.N = vertex_normals(a.mesh.V, a.mesh.F);
  t.stop("coefficients");

  const int res = options.input_res > 0 ? options.input_res : int(net.options.res);
  const TextureInputs in = texture_inputs(a.bare, c, model, res, face_mask);
  a.unwrap = in.unwrap;
  a.confidence = in.confidence;
  t.stop("unwrap");

  const auto maps = net.infer(in.tensors());
  t.stop("pix2pixhd");
  for (const auto& m : output_maps()) {
    const ColorSpace space = m.name == "diffuse" ? ColorSpace::sRGB : ColorSpace::Data;
    a.maps[m.name] = tensor_image(maps.at(m.name), space);
    if (!options.upscale) continue;
    auto it = options.sr_maps.count(m.name) ? upscalers.find(m.name) : upscalers.end();
    const auto hr = it != upscalers.end() ? it->second.infer(maps.at(m.name)) : bicubic_x4(maps.at(m.name), m.name);
    a.maps_hr[m.name] = tensor_image(hr, space);
    a.upscaled_with += (a.upscaled_with.empty() ? "" : ", ") + m.name + ": " +
                       (it != upscalers.end() ? "srgan" : "bicubic");
  }
  t.stop("upscale");

  // Relit previews: the diffuse map under three lights on the avatar's mesh, front view.
  const Image diffuse_linear = to_linear(a.maps.at("diffuse"));
  const Camera preview = view_camera("front", options.preview_size, Eigen::Vector3d::Zero(), 1000);
  for (int l = 1; l <= 3; ++l) {
    ShadeOptions so;
    so.texture = &diffuse_linear;
    so.gamma = texgen::sample_light(l - 1, kPreviewLightSeed);  // the default light, then two random ones
    so.cull_back_faces = true;
    a.previews.push_back(to_srgb(render_frame(a.mesh, preview, so).colour));
  }
  t.stop("previews");
  return a;
}

Avatar avatar_from_photo(const Image& photo, const std::string& source, const FaceFinder& detector,
                         const MorphableModel& model, const AvatarNets& nets, const Demakeup& G,
                         const AvatarOptions& options, const Image& face_mask) {
  const auto t = Clock::now();
  const double cpu = cpu_now();
  detect::check_photo(photo, source);
  const Image srgb = as_srgb(photo);
  const auto faces = detector(srgb);
  if (faces.empty()) throw InvalidInput(source, "has no face the detector finds", "give a photo with a visible face");
  const detect::Similarity similarity = detect::alignment(faces.front());
  const Image aligned = detect::warp_aligned(srgb, similarity, detect::kAlignedSize);
  if (!face_mask.empty() && (face_mask.width != photo.width || face_mask.height != photo.height))
    throw InvalidInput("face mask", fmt::format("is {}x{}, the photo {}x{}", face_mask.width, face_mask.height,
                                                photo.width, photo.height),
                       "give the face segmentation of this photo, at its size");
  const Image aligned_mask =
      face_mask.empty() ? Image() : detect::warp_aligned(first_channel(face_mask), similarity, detect::kAlignedSize);
  const double detect_seconds = since(t), detect_cpu = cpu_now() - cpu;
  Avatar a = avatar_from_aligned(aligned, detect::transform(similarity, faces.front()), model, nets, G, options,
                                 aligned_mask);
  a.seconds["detect_align"] = detect_seconds;
  a.cpu_seconds["detect_align"] = detect_cpu;
  return a;
}

Image read_face_mask(const std::string& path, const Image& photo) {
  const Image mask = read_image(path);
  if (mask.width != photo.width || mask.height != photo.height)
    throw InvalidInput(path, fmt::format("is {}x{}, the photo {}x{}", mask.width, mask.height, photo.width, photo.height),
                       "give the face segmentation of this photo, at its size");
  return first_channel(mask);
}

void AvatarOptions::check() const {
  if (input_res != 0 && (input_res < 64 || input_res > 8192))
    throw InvalidInput("--input-res", std::to_string(input_res) + " must be 0 or lie in [64, 8192]",
                       "0 takes the texture run's size");
  if (preview_size < 16 || preview_size > 4096)
    throw InvalidInput("--preview-size", std::to_string(preview_size) + " is outside [16, 4096]", "e.g. 512 (default)");
  for (const std::string& name : sr_maps) {
    bool known = false;
    for (const auto& m : output_maps()) known |= m.name == name;
    if (!known)
      throw InvalidInput("--sr-maps", "names '" + name + "', not a texture map",
                         "list some of diffuse, normal, roughness, specular (comma-separated; empty for none)");
  }
  landmark_fit.check();
  photometric.check();
}

void EvaluateOptions::check() const {
  if (faces.empty()) throw InvalidInput("--faces", "is missing", "give the held-out faces split (texgen faces)");
  if (output.empty()) throw InvalidInput("-o", "names no report folder", "give the report's output folder");
  if (max_samples < 0) throw InvalidInput("--max-samples", "must not be negative", "0 takes every sample");
  avatar.check();
}

std::set<std::string> parse_map_list(const std::string& list, const std::string& option) {
  std::set<std::string> out;
  size_t start = 0;
  while (start <= list.size()) {
    const size_t end = std::min(list.find(',', start), list.size());
    const std::string name = list.substr(start, end - start);
    if (!name.empty()) {
      bool known = false;
      for (const auto& m : output_maps()) known |= m.name == name;
      if (!known)
        throw InvalidInput(option + " " + list, "names '" + name + "', not a texture map",
                           "list some of diffuse, normal, roughness, specular (comma-separated; empty for none)");
      out.insert(name);
    }
    start = end + 1;
  }
  return out;
}

namespace {

// Runs the jobs on `threads` threads, each taking the next job in order (largest first, so none waits at the
// end); every job ends before the first error is rethrown.
void run_jobs(const std::vector<std::function<void()>>& jobs, int threads) {
  std::atomic<size_t> next{0};
  std::vector<std::exception_ptr> errors(jobs.size());
  auto worker = [&] {
    for (size_t i = next++; i < jobs.size(); i = next++) try {
        jobs[i]();
      } catch (...) {
        errors[i] = std::current_exception();
      }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < std::max(1, threads); ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace

void write_avatar(const std::string& dir, const Avatar& a, const nlohmann::json& report, int threads) {
  const auto t0 = Clock::now();
  const double cpu0 = cpu_now();
  AtomicDirectory out(dir);
  const std::string d = out.path();
  make_directories(d + "/maps");
  write_image(d + "/aligned.png", a.aligned);
  write_image(d + "/bare.png", a.bare);
  write_image(d + "/fit.png", a.fit);
  write_image(d + "/unwrap.png", a.unwrap);
  write_image(d + "/confidence.png", a.confidence);
  write_coefficients(d + "/coefficients.json", a.coefficients);
  if (a.coefficients.gamma) write_light_files(d, *a.coefficients.gamma);  // for engines
  write_mesh(d + "/mesh.obj", a.mesh);
  // Each map is encoded once, on `threads` threads, largest first; the GLB embeds the files' bytes (its roughness
  // texture is the grey roughness PNG itself, glb.h) plus one grey+alpha specular texture (core/png_encoding.h's
  // encoding: bench/BENCHMARKS.md gives its time and size).
  const bool hr = !a.maps_hr.empty();
  const auto& glb_maps = hr ? a.maps_hr : a.maps;
  std::map<std::string, std::string> png;  // file name under maps/ -> bytes
  std::string specular_glb;
  for (const auto& [name, image] : a.maps_hr) png[name + "_hr.png"];
  for (const auto& [name, image] : a.maps) png[name + ".png"];
  std::vector<std::function<void()>> jobs;
  auto encode = [&](std::string& bytes, const Image& image, const std::string& path) {
    jobs.push_back([&bytes, &image, path] {
      bytes = encode_png(image, 8);
      if (!path.empty()) write_file_atomic(path, bytes);
    });
  };
  for (const auto& m : output_maps())  // the 3-channel maps first
    if (hr) encode(png[m.name + "_hr.png"], a.maps_hr.at(m.name), d + "/maps/" + m.name + "_hr.png");
  const Image specular = specular_texture(glb_maps.at("specular"));
  encode(specular_glb, specular, "");
  for (const auto& m : output_maps()) encode(png[m.name + ".png"], a.maps.at(m.name), d + "/maps/" + m.name + ".png");
  run_jobs(jobs, threads);
  const std::string suffix = hr ? "_hr.png" : ".png";
  write_glb(d + "/avatar.glb", a.mesh,
            PbrPngs{png.at("diffuse" + suffix), png.at("normal" + suffix), png.at("roughness" + suffix), specular_glb});
  for (size_t i = 0; i < a.previews.size(); ++i)
    write_image(d + "/preview_light" + std::to_string(i + 1) + ".png", a.previews[i]);
  nlohmann::json r = report;
  r["seconds"] = a.seconds;
  r["seconds"]["write"] = since(t0);  // every file but this report
  r["cpu_seconds"] = a.cpu_seconds;
  r["cpu_seconds"]["write"] = cpu_now() - cpu0;
  r["upscaled_with"] = a.upscaled_with;
  r["coefficients_from"] = a.coefficients_from;
  r["sizes"] = {{"aligned", a.aligned.width}, {"maps", a.maps.at("diffuse").width},
                {"maps_hr", a.maps_hr.empty() ? 0 : a.maps_hr.at("diffuse").width}};
  write_file_atomic(d + "/report.json", r.dump(2) + "\n");
  out.commit();
}

AvatarNets load_avatar_nets(const std::string& model_path, const std::string& texture_run,
                            const std::vector<std::string>& upscale_runs, const std::string& device,
                            const std::string& teacher_run) {
  const uint32_t model_crc = shards::file_crc32(model_path);
  auto check_model = [&](const nlohmann::json& config, const std::string& run) {
    if (!config.contains("model_crc32") || config["model_crc32"].is_null()) return;
    const auto trained = config["model_crc32"].get<uint32_t>();
    if (trained != model_crc)
      throw InvalidInput(run, fmt::format("was trained on data of another morphable model (CRC-32 {:08x}; {} is {:08x})",
                                          trained, model_path, model_crc),
                         "give the model its dataset was made with, or retrain on this model's dataset");
  };
  AvatarNets nets;
  nets.texture = TextureNet::load(texture_run, torch::Device(device));
  check_model(nets.texture.config, texture_run);
  for (const auto& run : upscale_runs) {
    Upscaler up = Upscaler::load(run, torch::Device(device));
    check_model(up.config, run);
    const std::string map = up.options.map;
    if (nets.upscalers.count(map))
      throw InvalidInput(run, "upscales the " + map + " map, as another --upscale run does",
                         "give one upscale run per map type");
    nets.upscalers.emplace(map, std::move(up));
  }
  if (!teacher_run.empty())
    nets.F = std::make_shared<const recon::TrainedRecon>(
        recon::load_recon(teacher_run, recon::FaceModel::load(model_path), torch::Device(device)));
  return nets;
}

// ---- evaluate ----

namespace {

struct Scores {
  double rmse = 0, psnr = 0, ssim = 0;
};

// RMSE (0–255 scale) and PSNR over the layout's texels, SSIM over the whole (layout-masked) map.
Scores compare(const torch::Tensor& a, const torch::Tensor& b, const torch::Tensor& layout) {
  auto m = layout.expand_as(a);
  const double count = m.sum().item<double>();
  const double mse = ((a - b).pow(2) * m).sum().item<double>() / std::max(count, 1.0);
  Scores s;
  s.rmse = 255 * std::sqrt(mse);
  s.psnr = mse > 0 ? 10 * std::log10(1 / mse) : 100;
  s.ssim = losses::ssim(a * m, b * m).mean().item<double>();
  return s;
}

std::map<std::string, torch::Tensor> as_tensors(const std::map<std::string, Image>& maps) {
  std::map<std::string, torch::Tensor> out;
  for (const auto& [name, image] : maps) out[name] = image_tensor(image);
  return out;
}

torch::Tensor resized(const torch::Tensor& x, int64_t res) {
  namespace F = torch::nn::functional;
  if (x.size(2) == res) return x;
  return F::interpolate(x, F::InterpolateFuncOptions().size(std::vector<int64_t>{res, res}).mode(torch::kArea));
}

}  // namespace

std::string subject_key(const std::string& name) { return name.rfind("scan/", 0) == 0 ? name.substr(5) : name; }

detect::Landmarks68 sample_landmarks(const data::Batch& batch) {
  auto lm = batch.at("landmarks")[0];
  detect::Landmarks68 out;
  for (int i = 0; i < 68; ++i) out.row(i) << lm[i][0].item<double>(), lm[i][1].item<double>();
  return out;
}

void require_face_masks(const std::string& faces, const std::string& option) {
  const shards::Manifest manifest = shards::open_dataset(faces);
  shards::ShardReader reader(shards::shard_path(faces, manifest.shards.at(0)));
  shards::Sample first;
  if (reader.next(first) && !first.members.count("face.png"))
    throw InvalidInput(faces, "has no face.png (the face less its occluders, which texgen faces writes)",
                       "regenerate the faces, or give " + option + " to unwrap the whole face");
}

nlohmann::json evaluate_table1(const EvaluateOptions& options, const MorphableModel& model, const AvatarNets& nets,
                               const Demakeup& G) {
  options.check();
  if (!G)
    throw InvalidInput("--bareskin", "is needed: Table 1 compares the maps with and without BareSkinNet",
                       "give the BareSkinNet run (bareskin train bareskin)");
  const int64_t res = options.avatar.input_res > 0 ? options.avatar.input_res : nets.texture.options.res;
  AvatarOptions ao = options.avatar;
  ao.upscale = false;

  // True maps per subject (the first texture sample of each), and the 4K diffuse where the split has it.
  std::map<std::string, std::map<std::string, torch::Tensor>> truth;
  if (!options.textures.empty()) {
    data::LoaderOptions lo;
    lo.dataset = options.textures;
    lo.required = {"diffuse.png", "normal.png", "roughness.png", "specular.png", "json"};
    lo.batch_size = 1;
    lo.shuffle_buffer = 0;
    data::ShardLoader loader(lo);
    for (int64_t i = 0; i < loader.epoch_size(); ++i) {
      auto b = loader.next();
      const std::string subject = subject_key(b.meta[0].value("subject", ""));
      if (truth.count(subject)) continue;
      for (const char* name : {"diffuse", "normal", "roughness", "specular", "diffuse_hr"})
        if (b.tensors.count(name)) truth[subject][name] = b.tensors.at(name);
    }
  }
  // Layout mask: the model's modelled texels at the maps' size.
  torch::Tensor layout;
  {
    const int R = model.appearance_resolution;
    auto m = torch::from_blob(const_cast<uint8_t*>(model.appearance_mask.data()), {1, 1, R, R}, torch::kUInt8)
                 .to(torch::kFloat32);
    layout = (resized(m, res) > 0.5).to(torch::kFloat32);
  }

  if (options.face_masks) require_face_masks(options.faces, "--no-face-masks");
  data::LoaderOptions lo;
  lo.dataset = options.faces;
  lo.required = {"makeup.png", "before.png", "json"};
  if (options.face_masks) lo.required.push_back("face.png");
  lo.batch_size = 1;
  lo.shuffle_buffer = 0;
  data::ShardLoader faces(lo);
  const int64_t limit = options.max_samples > 0 ? options.max_samples : faces.epoch_size();
  int64_t n = 0, skipped = 0;  // samples evaluated; samples without makeup (style "none") passed over

  // rows[condition][map] → per-sample scores; conditions: "without/ref", "with/ref", "without/truth", "with/truth".
  std::map<std::string, std::map<std::string, std::vector<Scores>>> rows;
  std::map<std::string, std::map<std::string, std::vector<double>>> per_subject;  // "with"/"without" → subject → PSNR
  std::string per_sample = "sample,subject,style,condition,against,map,rmse,psnr,ssim\n";
  std::vector<double> sr_psnr, bicubic_psnr;
  for (int64_t i = 0; i < faces.epoch_size() && n < limit; ++i) {
    auto b = faces.next();
    const auto& meta = b.meta[0];
    const std::string subject = subject_key(meta.value("subject", "")), style = meta.value("style", "");
    // A face without makeup has nothing to remove: its makeup image is its before image, so its maps without G
    // equal reference (a) exactly (PSNR capped at 100 dB, which would dominate the means).
    if (style == "none") {
      ++skipped;
      continue;
    }
    ++n;
    const auto lm = sample_landmarks(b);
    const Image makeup = tensor_image(b.at("makeup"), ColorSpace::sRGB);
    const Image before = tensor_image(b.at("before"), ColorSpace::sRGB);
    // (a) the before image without G for both rows (the paper's wording); (a') the before image through the same
    // pipeline as the row (with G for the with-G row), which asks whether the output is stable under makeup.
    // The face less its occluders: the same pixels in the makeup and before images (makeup is a layer on the skin).
    const Image mask = options.face_masks ? tensor_image(b.at("face"), ColorSpace::Data) : Image();
    const auto ref = as_tensors(avatar_from_aligned(before, lm, model, nets, {}, ao, mask).maps);
    const auto ref_with = as_tensors(avatar_from_aligned(before, lm, model, nets, G, ao, mask).maps);
    const auto without = as_tensors(avatar_from_aligned(makeup, lm, model, nets, {}, ao, mask).maps);
    const auto with = as_tensors(avatar_from_aligned(makeup, lm, model, nets, G, ao, mask).maps);
    for (const auto& [condition, maps, same] :
         {std::tuple{"without", &without, &ref}, std::tuple{"with", &with, &ref_with}}) {
      for (const auto& m : output_maps()) {
        const Scores s = compare(maps->at(m.name), ref.at(m.name), layout);
        rows[std::string(condition) + "/ref"][m.name].push_back(s);
        per_sample += fmt::format("{},{},{},{},reference,{},{:.4f},{:.4f},{:.5f}\n", b.keys[0], subject, style,
                                  condition, m.name, s.rmse, s.psnr, s.ssim);
        const Scores ss = compare(maps->at(m.name), same->at(m.name), layout);
        rows[std::string(condition) + "/same"][m.name].push_back(ss);
        per_sample += fmt::format("{},{},{},{},reference_same_pipeline,{},{:.4f},{:.4f},{:.5f}\n", b.keys[0], subject,
                                  style, condition, m.name, ss.rmse, ss.psnr, ss.ssim);
        if (m.name == "diffuse") per_subject[condition][subject].push_back(s.psnr);
        auto t = truth.find(subject);
        if (t != truth.end()) {
          const Scores st = compare(maps->at(m.name), resized(t->second.at(m.name), res), layout);
          rows[std::string(condition) + "/truth"][m.name].push_back(st);
          per_sample += fmt::format("{},{},{},{},truth,{},{:.4f},{:.4f},{:.5f}\n", b.keys[0], subject, style,
                                    condition, m.name, st.rmse, st.psnr, st.ssim);
        }
      }
    }
    spdlog::info("evaluate: sample {}/{} ({})", n, limit, b.keys[0]);
  }
  // SRGAN vs bicubic on the true high-resolution diffuse (4K in a 4K dataset): the true map box-filtered ×4 down,
  // then up again.
  int64_t hr_size = 0;
  for (const auto& [subject, maps] : truth) {
    auto it = maps.find("diffuse_hr");
    if (it == maps.end()) continue;
    auto hr = it->second.slice(2, 0, it->second.size(2) / 4 * 4).slice(3, 0, it->second.size(3) / 4 * 4);
    hr_size = hr.size(3);
    auto lr = torch::nn::functional::avg_pool2d(hr, torch::nn::functional::AvgPool2dFuncOptions(4));
    bicubic_psnr.push_back(losses::psnr(bicubic_x4(lr, "diffuse"), hr).item<double>());
    auto up = nets.upscalers.find("diffuse");
    if (up != nets.upscalers.end()) sr_psnr.push_back(losses::psnr(up->second.infer(lr), hr).item<double>());
  }

  auto mean = [](const std::vector<Scores>& v, double Scores::*field) {
    double s = 0;
    for (const auto& x : v) s += x.*field;
    return v.empty() ? std::nan("") : s / double(v.size());
  };
  auto mean_d = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? std::nan("") : s / double(v.size());
  };
  const std::string coefficients_from = nets.F ? "F" : "mm-fit";
  nlohmann::json summary = {{"samples", n}, {"skipped_without_makeup", skipped}, {"maps_size", res}, {"subjects_with_truth", truth.size()},
                            {"coefficients_from", coefficients_from}, {"face_masks", options.face_masks}};
  std::string md = fmt::format(
      "Table 1 protocol on {} held-out samples with makeup ({} without makeup passed over), maps {}², coefficients by "
      "{}, {} (RMSE on the 0–255 scale, PSNR dB, SSIM; over the UV layout).\n\n| metric | against | w/o BareSkinNet | w/ BareSkinNet | better |\n"
      "|---|---|---|---|---|\n",
      n, skipped, res, coefficients_from == "F" ? "the network F" : "mm-fit",
      options.face_masks ? "unwraps masked by each face's face.png" : "unwraps unmasked");
  std::string csv = "metric,map,against,without,with\n";
  std::map<std::string, int> improved, total;  // per column: "ref" (a), "same" (a'), "truth" (b)
  const std::map<std::string, std::string> column_name = {{"ref", "(a) before-makeup output, without G"},
                                                          {"same", "(a') before-makeup output, same pipeline"},
                                                          {"truth", "(b) true maps"}};
  for (const auto& [metric, field, higher] :
       {std::tuple{"RMSE", &Scores::rmse, false}, std::tuple{"PSNR", &Scores::psnr, true},
        std::tuple{"SSIM", &Scores::ssim, true}})
    for (const char* against : {"ref", "same", "truth"})
      for (const auto& m : output_maps()) {
        const auto& wo = rows[std::string("without/") + against][m.name];
        const auto& w = rows[std::string("with/") + against][m.name];
        if (wo.empty()) continue;
        const double a = mean(wo, field), b = mean(w, field);
        const bool better = higher ? b > a : b < a;
        ++total[against];
        improved[against] += better;
        md += fmt::format("| {} ({}) | {} | {:.4f} | {:.4f} | {} |\n", metric, m.name, column_name.at(against), a, b,
                          better ? "yes" : "no");
        csv += fmt::format("{},{},{},{:.6f},{:.6f}\n", metric, m.name, against, a, b);
        summary["table"][metric][m.name][against] = {{"without", a}, {"with", b}};
      }
  summary["improved_of_12"] = improved["ref"];
  summary["improved_of_12_same_pipeline"] = improved["same"];
  if (total["truth"] > 0) summary["improved_of_12_truth"] = improved["truth"];
  // Stability: the spread of the diffuse PSNR (against the reference) over each subject's makeup conditions.
  for (const char* condition : {"without", "with"}) {
    std::vector<double> spreads;
    for (const auto& [subject, v] : per_subject[condition]) {
      if (v.size() < 2) continue;
      const double mu = mean_d(v);
      double var = 0;
      for (double x : v) var += (x - mu) * (x - mu);
      spreads.push_back(std::sqrt(var / double(v.size())));
    }
    summary["stability_psnr_sd"][condition] = mean_d(spreads);
  }
  summary["srgan_psnr_4k"] = mean_d(sr_psnr);
  summary["bicubic_psnr_4k"] = mean_d(bicubic_psnr);
  auto spread = [&](const char* c) {
    const double v = summary["stability_psnr_sd"][c].get<double>();
    return std::isfinite(v) ? fmt::format("{:.3f}", v) : std::string("n/a (one condition per subject)");
  };
  md += fmt::format("\n{} of {} reference-column figures improve with BareSkinNet. Diffuse PSNR spread over a subject's "
                    "conditions (dB, mean SD): w/o {}, w/ {}.\n",
                    improved["ref"], total["ref"], spread("without"), spread("with"));
  md += fmt::format("\n{} of {} figures of column (a') improve with BareSkinNet (the with-G row against the "
                    "before-makeup image through G too: how stable the maps stay under makeup).\n",
                    improved["same"], total["same"]);
  if (total["truth"] > 0)
    md += fmt::format("\n{} of {} true-map figures (column b) improve with BareSkinNet.\n", improved["truth"],
                      total["truth"]);
  if (!bicubic_psnr.empty())
    md += fmt::format("\n×4 on the true {}² diffuse ({} subjects): SRGAN {:.2f} dB, bicubic {:.2f} dB.\n", hr_size,
                      bicubic_psnr.size(), mean_d(sr_psnr), mean_d(bicubic_psnr));

  AtomicDirectory out(options.output);
  write_file_atomic(out.path() + "/table.md", md);
  write_file_atomic(out.path() + "/table.csv", csv);
  write_file_atomic(out.path() + "/per_sample.csv", per_sample);
  write_file_atomic(out.path() + "/summary.json", summary.dump(2) + "\n");
  for (const auto& [metric, field] : {std::pair{"PSNR", &Scores::psnr}, std::pair{"RMSE", &Scores::rmse}}) {
    Chart chart;
    chart.title = std::string(metric) + " per map vs the before-makeup output (a), (a') (x: 1 diffuse, 2 normal, "
                  "3 roughness, 4 specular)";
    chart.x_label = "map";
    chart.y_label = metric;
    chart.y_from_zero = false;
    // Without G, (a) and (a') are the same reference: one line; with G, one line per reading.
    for (const auto& [row, label] : {std::pair{"without/ref", "without BareSkinNet"},
                                     std::pair{"with/ref", "with, vs (a)"},
                                     std::pair{"with/same", "with, vs (a')"}}) {
      ChartSeries s{label, {}, {}};
      for (size_t k = 0; k < output_maps().size(); ++k) {
        s.x.push_back(double(k + 1));
        s.y.push_back(mean(rows[row][output_maps()[k].name], field));
      }
      chart.series.push_back(s);
    }
    write_file_atomic(out.path() + "/" + std::string(metric == std::string("PSNR") ? "psnr" : "rmse") + ".svg",
                      svg_line_chart(chart));
  }
  out.commit();
  return summary;
}

void RunFilesOptions::check() const {
  if (photo.empty() || output.empty() || model.empty() || texture.empty())
    throw InvalidInput("run", "needs a photo, -o, --model and --texture", "see run --help");
  if (threads < 1) throw InvalidInput("--threads", "must be at least 1", "e.g. --threads 2");
  avatar.check();
}

RunFilesResult run_files(const RunFilesOptions& o) {
  o.check();
  std::vector<std::string> inputs = {o.photo,     o.model,     o.texture, o.bareskin,
                                     o.teacher,   o.landmarks, o.weights, o.face_mask};
  inputs.insert(inputs.end(), o.upscale.begin(), o.upscale.end());
  check_output_apart(o.output, inputs);
  const Image photo = read_image(o.photo);
  detect::check_photo(photo, o.photo);  // before the nets load
  const Image face_mask = o.face_mask.empty() ? Image() : read_face_mask(o.face_mask, photo);
  const auto t0 = std::chrono::steady_clock::now();
  nlohmann::json load;  // wall seconds per part of the loading
  auto lap = [&load, t = t0](const char* part) mutable {
    const auto now = std::chrono::steady_clock::now();
    load[part] = std::chrono::duration<double>(now - t).count();
    t = now;
  };
  const MorphableModel model = read_model(o.model);
  lap("model");
  const AvatarNets nets = load_avatar_nets(o.model, o.texture, o.upscale, o.device, o.teacher);
  lap("nets");
  const Demakeup G = o.bareskin.empty() ? Demakeup{} : load_demakeup(o.bareskin, o.device);
  lap("bareskin");
  FaceFinder detector;
  if (!o.landmarks.empty()) {
    const detect::Landmarks68 points = read_image_landmarks(o.landmarks, photo.width, photo.height).points;
    detector = [points](const Image&) { return std::vector<detect::Landmarks68>{points}; };
  } else {
    auto face_api = std::make_shared<detect::FaceApi>(o.weights.empty() ? detect::default_face_api_folder() : o.weights);
    detector = [face_api](const Image& srgb) {
      std::vector<detect::Landmarks68> faces;
      for (const detect::Face& f : face_api->detect(detect::photo_tensor(srgb, "photo"), {})) faces.push_back(f.points);
      return faces;
    };
  }
  lap("photo_detector");
  const double load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const auto t1 = std::chrono::steady_clock::now();
  const Avatar avatar = avatar_from_photo(photo, o.photo, detector, model, nets, G, o.avatar, face_mask);
  RunFilesResult result;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  result.upscaled_with = avatar.upscaled_with;
  write_avatar(o.output, avatar,
               {{"photo", o.photo}, {"model", o.model}, {"texture", o.texture}, {"upscale", o.upscale},
                {"bareskin", o.bareskin}, {"teacher", o.teacher}, {"face_mask", o.face_mask}, {"sr_maps", o.sr_maps},
                {"device", o.device},
                {"load_seconds", load_seconds}, {"load_seconds_by_part", load}, {"pipeline_seconds", result.seconds}},
               o.threads);
  return result;
}

}  // namespace bareskin::texture
