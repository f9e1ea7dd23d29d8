#include "texgen/make_dataset.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <random>

#include "core/error.h"
#include "core/hash.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/png.h"
#include "core/png_encoding.h"
#include "core/scan_folder.h"
#include "render/rasterize.h"
#include "texgen/face_world.h"  // kDefaultRoughness, kDefaultSpecular
#include "texgen/member_quantize.h"
#include "fitting/multiview_fit.h"
#include "texgen/occlusion_masks.h"
#include "core/shards.h"
#include "fitting/view_calibration.h"
#include "uvtools/bake.h"

namespace bareskin::texgen {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* const kSplits[3] = {"train", "val", "test"};
const char* const kMaps[4] = {"diffuse", "normal", "roughness", "specular"};

// One unit of work: a few subjects of one split, or a batch of CelebAMask photos.
struct Unit {
  int id = 0;
  int split = -1;  // -1: CelebAMask photos
  int local = 0;   // shard number inside its split
  std::vector<int> subjects;  // indices into the sorted subject list
  std::vector<int> photos;    // CelebAMask ids
};

std::string numbered(const std::string& prefix, int n) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "-%06d", n);
  return prefix + buf;
}

uint64_t fnv1a(const std::string& s) { return bareskin::fnv1a(s.data(), s.size()); }

// Members in the project's PNG encoding (core/png_encoding.h); the bytes depend only on the pixels.
std::string png8(const Image& img) { return encode_png(img, 8); }

json vec(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

json coefficients_json(const Coefficients& c) {
  json j = {{"alpha", vec(c.alpha)}, {"beta", vec(c.beta)}, {"delta", vec(c.delta)},
            {"rotation", vec(c.rotation)}, {"translation", vec(c.translation)}};
  if (c.gamma) j["gamma"] = *c.gamma;
  return j;
}

json points_json(const Landmarks68& p) {
  json j = json::array();
  for (int k = 0; k < 68; ++k) j.push_back({p(k, 0), p(k, 1)});
  return j;
}

std::vector<std::string> list_subjects(const std::string& registered) {
  if (!fs::is_directory(registered))
    throw InvalidInput(registered, "is not a folder", "give the folder `bareskin scan register` wrote");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(registered))
    if (e.is_directory() && e.path().filename().string()[0] != '.') names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  if (names.empty()) throw InvalidInput(registered, "holds no subject folders", "give the folder `bareskin scan register` wrote");
  return names;
}

// The maps a subject lacks besides its diffuse (a diffuse-only scan): filled in its targets (fill_map), and named in
// its samples' JSON as "filled_maps".
std::vector<std::string> missing_maps(const std::string& dir) {
  std::vector<std::string> missing;
  for (const char* m : kMaps)
    if (std::string(m) != "diffuse" && find_scan_map(dir, m).empty()) missing.push_back(m);
  return missing;
}

// A missing target map at `size`: flat normals (0.5, 0.5, 1) everywhere, roughness and specular the constants 3DMM
// subjects of `texgen faces` get (kDefaultRoughness, kDefaultSpecular) inside the layout's islands and 0 outside, as
// baked maps hold outside the charts.
Image fill_map(const std::string& map, const UvIslands& islands) {
  const int n = islands.size();
  if (map == "normal") {
    Image out(n, n, 3, ColorSpace::Data);
    for (size_t i = 0; i < out.pixels.size(); i += 3) {
      out.pixels[i] = out.pixels[i + 1] = 0.5f;
      out.pixels[i + 2] = 1.f;
    }
    return out;
  }
  const float value = map == "roughness" ? kDefaultRoughness : kDefaultSpecular;
  std::vector<uint8_t> mask;
  islands.mask_rows(0, n, mask);
  Image out(n, n, 1, ColorSpace::Data);
  for (size_t i = 0; i < mask.size(); ++i) out.pixels[i] = mask[i] ? value : 0.f;
  return out;
}

// What can be seen without reading a subject's data: its diffuse map exists and is large enough for the targets.
void check_subject_files(const std::string& dir, const TextureDatasetOptions& o) {
  if (find_scan_map(dir, "diffuse").empty())
    throw InvalidInput(dir, "has no diffuse map", "register the scan with its diffuse map, or pass --keep-going");
  const ImageFileInfo info = probe_image(find_scan_map(dir, "diffuse"));
  for (int size : {o.target_res, o.hr_res}) {
    if (size <= 0) continue;
    if (size > info.width || info.width % size != 0)
      throw InvalidInput(find_scan_map(dir, "diffuse"),
                         "is " + std::to_string(info.width) + "², which " + std::to_string(size) + " does not divide",
                         "pass --target-res/--hr-res that divide the maps' size (--hr-res 0: no high-res targets)");
  }
}

// Splits the sorted subjects by identity: a seeded permutation, then test, val and the rest train.
std::array<std::vector<int>, 3> split_subjects(int n, const std::array<double, 3>& fractions, uint64_t seed) {
  std::vector<int> order(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) order[size_t(i)] = i;
  std::mt19937_64 rng(seed ^ 0x5EEDull);
  for (int i = n - 1; i > 0; --i) std::swap(order[size_t(i)], order[size_t(rng() % uint64_t(i + 1))]);
  const double total = fractions[0] + fractions[1] + fractions[2];
  auto count = [&](double f) { return f > 0 ? std::max(1, int(std::lround(n * f / total))) : 0; };
  int n_test = count(fractions[2]), n_val = count(fractions[1]);
  while (n_test + n_val >= n && (n_test > 0 || n_val > 0)) (n_val >= n_test ? n_val : n_test)--;
  std::array<std::vector<int>, 3> out;
  for (int i = 0; i < n; ++i) out[size_t(i < n_test ? 2 : i < n_test + n_val ? 1 : 0)].push_back(order[size_t(i)]);
  for (auto& s : out) std::sort(s.begin(), s.end());
  return out;
}

// The template layout's rasters, built once and shared by every subject: its island rasters, one per registered-map
// size (the layout half of a bake; the bake thread's), and its UV raster at the input size (what every unwarp and
// UV map of a subject's fit rasterises; the main thread's).
class LayoutRasters {
 public:
  LayoutRasters(const Mesh& layout, int input_res) : uv(rasterize_uv(layout, input_res)), layout_(layout) {}
  const UvIslands& at(int size) {  // from any bake thread
    std::lock_guard<std::mutex> lock(mutex_);
    auto& r = rasters_[size];
    if (!r) r = std::make_unique<UvIslands>(layout_, size);
    return *r;
  }
  const RasterOutput uv;

 private:
  const Mesh& layout_;
  std::mutex mutex_;
  std::map<int, std::unique_ptr<UvIslands>> rasters_;
};

// A baked map as the 8-bit PNG member: the value a 16-bit PNG file of the bake would hold (diffuse sRGB-encoded),
// then 8 bits (the members were once made through such files; the bytes stay the same), by MemberQuantizer's tables.
std::string baked_member(Image image) {
  const bool encode = image.color_space == ColorSpace::Linear;
  const size_t C = size_t(image.channels), colour = C == 4 ? 3 : C, n = image.pixels.size();
  const MemberQuantizer& as_colour = encode ? MemberQuantizer::colour() : MemberQuantizer::data();
  const MemberQuantizer& as_data = MemberQuantizer::data();
  std::unique_ptr<unsigned char[]> samples(new unsigned char[n]);  // every byte written below
  for (size_t i = 0; i < n; i += C)
    for (size_t c = 0; c < C; ++c) samples[i + c] = (c < colour ? as_colour : as_data)(image.pixels[i + c]);
  const int width = image.width, height = image.height;
  std::vector<float>().swap(image.pixels);  // the float map goes before deflate
  return encode_png_samples(samples.get(), width, height, int(C), 8, PngEncoding{});
}

// The subject's four maps baked to the target sizes (in memory, through the cached layout raster) as PNG members, on
// a thread of its own beside the subject's renders and fits; each baked map is encoded on its own thread as it comes.
// The diffuse comes first and is also handed over as the renders' texture (at the smallest baked size at least the
// render size, else the largest), so the maps are decoded once per subject.
class TargetBake {
 public:
  TargetBake(const std::string& dir, LayoutRasters& rasters, const TextureDatasetOptions& o)
      : texture_future_(texture_.get_future()) {
    members_ = std::async(std::launch::async, [this, dir, &rasters, &o] { return run(dir, rasters, o); });
  }
  // The diffuse (linear RGB) for the renders; blocks until it is baked, rethrows the bake's error.
  Image texture() { return texture_future_.get(); }
  // The target members; blocks until every map is baked and encoded, rethrows the bake's error.
  std::map<std::string, std::string> members() { return members_.get(); }
  double seconds() const { return seconds_; }  // the bake thread's wall time (valid after members())

 private:
  std::map<std::string, std::string> run(const std::string& dir, LayoutRasters& rasters, const TextureDatasetOptions& o) {
    const auto t0 = std::chrono::steady_clock::now();
    bool texture_set = false;
    try {
      MapResizeOptions bake;
      bake.sizes = {o.target_res};
      if (o.hr_res > 0 && o.hr_res != o.target_res) bake.sizes.push_back(o.hr_res);
      int texture_size = *std::max_element(bake.sizes.begin(), bake.sizes.end());
      for (int size : bake.sizes)
        if (size >= o.sample.render_size) texture_size = std::min(texture_size, size);
      std::vector<std::pair<std::vector<std::string>, std::future<std::string>>> jobs;
      const BakedMapSink sink = [&](const std::string& map, int size, Image image) {
        if (map == "diffuse" && size == texture_size) {
          if (image.channels < 3)
            throw InvalidInput(find_scan_map(dir, "diffuse"), "is not an RGB map", "give the registered diffuse map");
          texture_.set_value(image);
          texture_set = true;
        }
        std::vector<std::string> names;
        if (size == o.target_res) names.push_back(map + ".png");
        if (o.hr_res > 0 && size == o.hr_res) names.push_back(map + "_hr.png");
        jobs.emplace_back(std::move(names), std::async(std::launch::async, [img = std::move(image)]() mutable {
                            return baked_member(std::move(img));
                          }));
      };
      bake_maps(dir, &rasters.at(map_set_size(dir)), bake, sink);
      for (const std::string& map : missing_maps(dir))
        for (int size : bake.sizes) sink(map, size, fill_map(map, rasters.at(size)));
      if (!texture_set) throw InvalidInput(dir, "has no diffuse map", "register the scan with its maps, or remove the subject");
      std::map<std::string, std::string> members;
      for (auto& [names, job] : jobs) {
        const std::string png = job.get();
        for (const std::string& n : names) members[n] = png;
      }
      for (const char* m : kMaps)
        BS_CHECK(members.count(std::string(m) + ".png"), "make-dataset: the bake gave no " + std::string(m) + " map");
      seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      return members;
    } catch (...) {
      if (!texture_set) texture_.set_exception(std::current_exception());
      throw;
    }
  }

  std::promise<Image> texture_;
  std::future<Image> texture_future_;
  double seconds_ = 0;
  std::future<std::map<std::string, std::string>> members_;  // last: its destructor waits for the thread
};

// A worker's subjects in the order it visits them, each one's target bake started as soon as the subject before it
// has its diffuse (beside that subject's renders, fits and remaining maps), so that a subject's renders do not wait
// for its maps to be read and no core idles while the main thread runs its one-threaded parts (the detector, the
// solvers). One bake ahead at most.
class BakeAhead {
 public:
  BakeAhead(std::vector<std::string> order, LayoutRasters& rasters, const TextureDatasetOptions& o)
      : order_(std::move(order)), rasters_(rasters), o_(o) {}
  // The bake of `dir`: the one started ahead for it, or a new one.
  std::unique_ptr<TargetBake> take(const std::string& dir) {
    if (next_ && next_dir_ == dir) return std::move(next_);
    next_.reset();  // started for a subject that was skipped: waits for its thread
    return std::make_unique<TargetBake>(dir, rasters_, o_);
  }
  // Starts the bake of the subject after `dir` in the order, if there is one.
  void start_after(const std::string& dir) {
    const auto it = std::find(order_.begin(), order_.end(), dir);
    if (it == order_.end() || it + 1 == order_.end() || next_) return;
    next_dir_ = *(it + 1);
    next_ = std::make_unique<TargetBake>(next_dir_, rasters_, o_);
  }

 private:
  std::vector<std::string> order_;
  LayoutRasters& rasters_;
  const TextureDatasetOptions& o_;
  std::string next_dir_;
  std::unique_ptr<TargetBake> next_;
};

struct SubjectOutput {
  std::vector<shards::Sample> samples, masks;
  json report;
};

SubjectOutput process_subject(const MorphableModel& model, const std::string& dir, int index, const std::string& split,
                              const TextureDatasetOptions& o, const FaceLandmarkDetector& detect,
                              LayoutRasters& rasters, BakeAhead& bakes) {
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  auto since = [](clock::time_point t) { return std::chrono::duration<double>(clock::now() - t).count(); };
  const std::unique_ptr<TargetBake> bake = bakes.take(dir);  // runs beside everything below until bake->members()
  Subject subject = load_subject_mesh(dir, model);
  subject.diffuse = bake->texture();
  bakes.start_after(dir);  // the next subject's maps are read while this one's renders and fits run
  const uint64_t subject_seed = o.seed * 0x9E3779B97F4A7C15ull ^ fnv1a(subject.name);
  SubjectOutput out;
  out.report = {{"subject", subject.name}, {"split", split}, {"lights", json::array()}};
  json& timing = out.report["seconds"];
  timing["load"] = since(t0);  // the mesh, and the wait for the bake's diffuse
  auto t = clock::now();
  const Image truth = resize_square(subject.diffuse, o.sample.input_res);
  double fit_s = 0, encode_s = 0;
  std::vector<ViewFit> unlit_fits;
  for (int l = 0; l < o.lights; ++l) {
    t = clock::now();
    const auto light = sample_light(l, subject_seed);
    std::vector<ViewFit> views = fit_views(model, subject, light, detect, o.sample, &rasters.uv);
    std::vector<const UnwarpResult*> unwraps;
    for (const ViewFit& v : views) unwraps.push_back(&v.unwrap);
    const MergedUnwrap merged = merge_by_confidence(unwraps, o.sample.merge_sharpness);
    const ModelUvMaps mm = model_uv_maps(model, views[0].fit, o.sample.input_res, &rasters.uv);
    fit_s += since(t);
    t = clock::now();
    shards::Sample sample;
    char key[16];
    std::snprintf(key, sizeof(key), "%08d", index * o.lights + l);
    sample.key = key;
    sample.members["unwrap.png"] = png8(to_srgb(merged.colour));
    sample.members["confidence.png"] = png8(merged.confidence);
    if (!mm.albedo.empty()) sample.members["mm_albedo.png"] = png8(to_srgb(mm.albedo));
    sample.members["mm_normal.png"] = png8(mm.normal);
    sample.members["mm_position.png"] = encode_png(mm.position, 16);
    if (o.with_renders)
      for (const ViewFit& v : views) {
        sample.members["render_" + v.name + ".png"] = png8(v.render);
        sample.members["bare_" + v.name + ".png"] = png8(v.bare);
      }
    int64_t layout = 0, seen = 0;
    for (size_t i = 0; i < merged.confidence.pixels.size(); ++i) seen += merged.confidence.pixels[i] > 0;
    json view_meta = json::array();
    for (const ViewFit& v : views) {
      layout = v.unwrap.in_layout;
      view_meta.push_back({{"name", v.name},
                           {"yaw_deg", v.yaw_deg},
                           {"coverage", double(v.unwrap.seen) / double(std::max<int64_t>(1, v.unwrap.in_layout))},
                           {"detector_error_px", v.detector_error_px},
                           {"landmark_rms_px", v.landmark_rms_px},
                           {"photometric_psnr_db", v.photometric_psnr_db},
                           {"shape_error_mm", v.shape_error_mm},
                           // this view's unwrap alone vs the truth over the texels it saw (the merge's inputs)
                           {"psnr_db_vs_truth", masked_psnr_srgb(v.unwrap.colour, truth, v.unwrap.confidence)},
                           {"alignment_rms", {v.alignment_rms_before, v.alignment_rms_after}},
                           {"coefficients", coefficients_json(v.fit)}});
    }
    const double psnr = masked_psnr_srgb(merged.colour, truth, merged.confidence);
    const std::vector<std::string> filled = missing_maps(dir);
    json meta = {{"subject", subject.name},
                 {"split", split},
                 {"light", l},
                 {"lighting", light},
                 {"unwrapped", o.sample.unwrap_lit ? "the lit render" : "the diffuse-only render"},
                 {"fitter", o.fitter},
                 {"landmark_fit", o.sample.landmark_fit_mode},
                 {"robust_landmarks", o.sample.landmark_robust_rounds},
                 {"landmark_calibration", o.landmark_calibration ? fs::path(o.landmark_calibration->source).filename().string() : ""},
                 {"views", view_meta},
                 {"unwrap", {{"coverage", double(seen) / double(std::max<int64_t>(1, layout))},
                             {"psnr_db_vs_truth", psnr},
                             {"merge", "confidence^" + std::to_string(o.sample.merge_sharpness) + " weighted mean"}}},
                 {"sizes", {{"render", o.sample.render_size}, {"fit", o.sample.fit_size}, {"input", o.sample.input_res},
                            {"target", o.target_res}, {"hr", o.hr_res}}},
                 {"mm_position", {{"offset_mm", mm.position_offset}, {"scale_mm", mm.position_scale},
                                  {"frame", "model (object) frame, unposed"}, {"decode", "mm = offset + scale * value"}}},
                 {"mm_fit_view", views[0].name}};
    if (!filled.empty()) meta["filled_maps"] = filled;  // targets filled by fill_map (diffuse-only scans)
    sample.members["json"] = meta.dump();
    out.samples.push_back(std::move(sample));
    encode_s += since(t);
    json light_report = meta;
    for (size_t i = 0; i < views.size(); ++i) {  // the reports (not the shards) carry the detector's and true landmarks
      json& v = light_report["views"][i];
      v.erase("coefficients");
      v["landmarks_detected_px"] = points_json(views[i].detected);
      v["landmarks_truth_px"] = points_json(views[i].truth_landmarks);
    }
    out.report["lights"].push_back(light_report);
    if (l == 0) unlit_fits = std::move(views);
  }
  t = clock::now();
  for (int k = 0; k < o.masks_per_subject; ++k) {
    const ViewFit& v = unlit_fits[size_t(k) % unlit_fits.size()];
    UvMask m = synthetic_mask(model, v.fit, o.sample.fit_size, o.occluders, subject_seed + 1000 + uint64_t(k),
                              o.sample.input_res, &rasters.uv);
    m.meta["subject"] = subject.name;
    m.meta["view"] = v.name;
    char key[16];
    std::snprintf(key, sizeof(key), "%08d", index * 1000 + k);
    out.masks.push_back({key, {{"mask.png", png8(m.mask)}, {"json", m.meta.dump()}}});
  }
  timing["masks"] = since(t);
  t = clock::now();
  std::map<std::string, std::string> targets = bake->members();
  timing["targets_wait"] = since(t);  // what the bake still needed after the fits and masks
  timing["bake"] = bake->seconds();   // the bake's own wall time, beside the rest (it may start before the subject)
  for (size_t i = 0; i < out.samples.size(); ++i) {
    if (i + 1 == out.samples.size()) out.samples[i].members.merge(targets);
    else out.samples[i].members.insert(targets.begin(), targets.end());
  }
  timing["fit_unwrap"] = fit_s;
  timing["encode"] = encode_s;
  timing["total"] = since(t0);
  return out;
}

// Runs one unit into a scratch folder and renames its shards into place; then its index entry.
void run_unit(const Unit& unit, const std::vector<std::string>& subjects, const MorphableModel& model,
              const TextureDatasetOptions& o, const FaceLandmarkDetector& detect,
              const FaceLandmarkDetector& detect_photo, LayoutRasters& rasters, BakeAhead& bakes,
              TextureDatasetReport& report, const std::function<void(const std::string&)>& step) {
  const std::string scratch = o.output + "/.tmp/" + numbered("unit", unit.id);
  fs::remove_all(scratch);
  struct Cleanup {
    std::string dir;
    ~Cleanup() {
      std::error_code ec;
      fs::remove_all(dir, ec);
    }
  } cleanup{scratch};
  json index = {{"unit", unit.id}, {"skipped", json::array()}, {"items", json::array()}};
  int64_t samples = 0, masks = 0;
  {
    shards::ShardWriter textures(scratch, "texture", 1 << 30), mask_writer(scratch, "mask", 1 << 30);
    auto skip = [&](const std::string& item, const Error& e) {
      if (!o.keep_going) throw;
      spdlog::warn("make-dataset: skipping {}: {}", item, e.what());
      index["skipped"].push_back({{"item", item}, {"reason", e.what()}});
    };
    for (int s : unit.subjects) {
      const std::string dir = o.registered + "/" + subjects[size_t(s)];
      step(subjects[size_t(s)]);
      try {
        check_subject_files(dir, o);
        SubjectOutput r = process_subject(model, dir, s, kSplits[unit.split], o, detect, rasters, bakes);
        for (const auto& x : r.samples) textures.write(x);
        for (const auto& x : r.masks) mask_writer.write(x);
        samples += int64_t(r.samples.size());
        masks += int64_t(r.masks.size());
        make_directories(o.output + "/reports");
        write_file_atomic(o.output + "/reports/" + subjects[size_t(s)] + ".json", r.report.dump(1) + "\n");
        index["items"].push_back(subjects[size_t(s)]);
      } catch (const InvalidInput& e) {
        skip(dir, e);
      } catch (const IoError& e) {
        skip(dir, e);
      }
    }
    for (int id : unit.photos) {
      step("CelebAMask photo " + std::to_string(id));
      try {
        const UvMask m = celebamask_mask(model, o.celebamask, id, detect_photo, o.sample.landmark_fit, o.sample.input_res);
        char key[16];
        std::snprintf(key, sizeof(key), "9%07d", id);
        mask_writer.write({key, {{"mask.png", png8(m.mask)}, {"json", m.meta.dump()}}});
        ++masks;
        index["items"].push_back(id);
      } catch (const InvalidInput& e) {
        skip(o.celebamask + "/CelebA-HQ-img/" + std::to_string(id), e);
      } catch (const IoError& e) {
        skip(o.celebamask + "/CelebA-HQ-img/" + std::to_string(id), e);
      }
    }
    const auto moved = [&](std::vector<shards::ShardInfo> written, const std::string& dir, const std::string& name) {
      if (written.empty()) return json(nullptr);
      BS_CHECK(written.size() == 1, "a unit writes one shard per set");
      make_directories(dir);
      fs::rename(scratch + "/" + written[0].name, dir + "/" + name);
      return json{{"name", name}, {"samples", written[0].samples}, {"crc32", written[0].crc32}, {"bytes", written[0].bytes}};
    };
    // Masks first: the texture shard's arrival (then the index) marks the unit done.
    index["mask"] = moved(mask_writer.finish(), o.output + "/masks", numbered("mask", unit.id) + ".tar");
    index["texture"] = unit.split < 0 ? json(nullptr)
                                      : moved(textures.finish(), o.output + "/" + kSplits[unit.split],
                                              numbered("texture", unit.local) + ".tar");
  }
  make_directories(o.output + "/.index");
  write_file_atomic(o.output + "/.index/" + numbered("unit", unit.id) + ".json", index.dump(1) + "\n");
  report.samples += samples;
  report.masks += masks;
}

// manifest.json of every split and of masks/, from the finished units' index entries.
void write_manifests(const std::vector<Unit>& units, const std::vector<std::string>& subjects,
                     const TextureDatasetOptions& o, const json& options_json, TextureDatasetReport& report) {
  std::array<shards::Manifest, 3> split_manifests;
  shards::Manifest masks;
  std::array<int, 3> expected{}, done{};
  int mask_units = 0, mask_done = 0;
  report.skipped.clear();
  for (const Unit& u : units) {
    const std::string path = o.output + "/.index/" + numbered("unit", u.id) + ".json";
    if (u.split >= 0) ++expected[size_t(u.split)];
    ++mask_units;
    if (!fs::exists(path)) continue;
    const json index = json::parse(read_file(path));
    if (u.split >= 0) ++done[size_t(u.split)];
    ++mask_done;
    for (const auto& s : index["skipped"]) report.skipped.push_back({s["item"], s["reason"]});
    auto info = [](const json& j) {
      return shards::ShardInfo{j["name"], j["samples"].get<int64_t>(), j["crc32"].get<uint32_t>(), j["bytes"].get<int64_t>()};
    };
    if (!index["texture"].is_null()) split_manifests[size_t(u.split)].shards.push_back(info(index["texture"]));
    if (!index["mask"].is_null()) masks.shards.push_back(info(index["mask"]));
  }
  json skipped = json::array();
  for (const auto& s : report.skipped) skipped.push_back({{"item", s.item}, {"reason", s.reason}});
  report.complete = mask_done == mask_units;
  for (int k = 0; k < 3; ++k) {
    json names = json::array();
    for (const Unit& u : units)
      if (u.split == k)
        for (int s : u.subjects) names.push_back(subjects[size_t(s)]);
    split_manifests[size_t(k)].metadata = {{"generator", "bareskin texgen make-dataset"}, {"kind", "texture"},
                                           {"split", kSplits[k]}, {"subjects", names},
                                           {"complete", done[size_t(k)] == expected[size_t(k)]},
                                           {"units", expected[size_t(k)]}, {"units_done", done[size_t(k)]},
                                           {"skipped", skipped}, {"options", options_json}};
    make_directories(o.output + "/" + kSplits[k]);
    shards::write_manifest(o.output + "/" + kSplits[k], split_manifests[size_t(k)]);
  }
  masks.metadata = {{"generator", "bareskin texgen make-dataset"}, {"kind", "mask"}, {"complete", report.complete},
                    {"units", mask_units}, {"units_done", mask_done}, {"options", options_json}};
  make_directories(o.output + "/masks");
  shards::write_manifest(o.output + "/masks", masks);
}

json options_to_json(const TextureDatasetOptions& o) {
  json views = json::array();
  for (const ViewSpec& v : o.sample.views) views.push_back({{"name", v.name}, {"yaw_deg", v.yaw_deg}});
  json occluders = json::array();
  for (Occluder x : o.occluders) occluders.push_back(to_string(x));
  return {{"views", views}, {"lights", o.lights}, {"fitter", o.fitter},
          {"landmark_fit", o.sample.landmark_fit_mode}, {"robust_landmarks", o.sample.landmark_robust_rounds},
          {"align_views", o.sample.align.rounds}, {"align_shape", o.sample.align.shape},
          {"align_size", o.sample.align.size}, {"align_landmark_weight", o.sample.align.landmark_weight},
          {"align_shape_prior", o.sample.align.shape_prior},
          {"landmark_regularisation", o.sample.landmark_fit.regularisation},
          {"landmark_calibration", o.landmark_calibration ? o.landmark_calibration->source : ""},
          {"view_calibration", o.sample.view_calibration_source}, {"render_size", o.sample.render_size},
          {"fit_size", o.sample.fit_size}, {"input_res", o.sample.input_res}, {"target_res", o.target_res},
          {"hr_res", o.hr_res}, {"merge_sharpness", o.sample.merge_sharpness},
          {"drop_background", o.sample.drop_background}, {"masks_per_subject", o.masks_per_subject},
          {"occluders", occluders}, {"celebamask_count", o.celebamask.empty() ? 0 : o.celebamask_count},
          {"split", o.split}, {"subjects_per_shard", o.subjects_per_shard}, {"seed", o.seed}};
}

}  // namespace

void TextureDatasetOptions::check() const {
  sample.check();
  if (lights < 1 || lights > 64) throw InvalidInput("--lights", "must lie in [1, 64]", "");
  if (fitter == "recon")
    throw InvalidInput("--fitter", "recon needs the teacher network F, which this build does not provide yet",
                       "use --fitter mm-fit");
  if (fitter != "mm-fit") throw InvalidInput("--fitter", "unknown fitter '" + fitter + "'", "use mm-fit");
  if (target_res < 16 || target_res > 16384) throw InvalidInput("--target-res", "must lie in [16, 16384]", "");
  if (hr_res != 0 && (hr_res < target_res || hr_res > 16384))
    throw InvalidInput("--hr-res", "must be 0 or lie in [--target-res, 16384]", "");
  if (masks_per_subject < 0 || masks_per_subject > 999) throw InvalidInput("--masks", "must lie in [0, 999]", "");
  if (masks_per_subject > 0 && occluders.empty()) throw InvalidInput("--occluders", "none given", "e.g. hair,glasses");
  if (celebamask_count < 0 || celebamask_per_shard < 1) throw InvalidInput("--celebamask-count", "must be >= 0", "");
  for (double f : split)
    if (!(f >= 0 && f <= 1)) throw InvalidInput("--split", "fractions must lie in [0, 1]", "e.g. 0.8,0.1,0.1");
  if (!(split[0] > 0)) throw InvalidInput("--split", "the train fraction must be positive", "e.g. 0.8,0.1,0.1");
  if (subjects_per_shard < 1) throw InvalidInput("--subjects-per-shard", "must be >= 1", "");
  if (shards < 1 || shard < 0 || shard >= shards)
    throw InvalidInput("--shard", "must lie in [0, --shards)", "e.g. --shard $SLURM_ARRAY_TASK_ID --shards 8");
  if (output.empty()) throw InvalidInput("-o", "no output folder", "give -o texture_shards/");
}

TextureDatasetReport make_texture_dataset(const TextureDatasetOptions& options, const FaceLandmarkDetector& detect,
                                          const FaceLandmarkDetector& detect_photo, const ProgressCallback& progress) {
  const auto start = std::chrono::steady_clock::now();
  options.check();
  TextureDatasetOptions o = options;
  TextureDatasetReport report;
  const std::vector<std::string> subjects = list_subjects(o.registered);
  report.subjects = int(subjects.size());
  const MorphableModel model = read_model(o.model);
  if (model.landmark_vertices.size() != 68)
    throw InvalidInput(o.model, "has no 68 landmark vertices", "build the model with `bareskin mm-build`");
  if (o.landmark_calibration) {
    try {
      o.sample.landmark_offsets = landmark_offsets(model, o.landmark_calibration->reference, o.landmark_calibration->offset);
    } catch (const InvalidInput& e) {
      throw InvalidInput(o.landmark_calibration->source, e.what(), "make it again with `bareskin landmarks calibrate`");
    }
  }
  if (o.sample.view_calibration) {
    const std::string used = o.landmark_calibration ? fs::path(o.landmark_calibration->source).filename().string() : "";
    if (o.sample.view_calibration->landmark_calibration != used)
      throw InvalidInput(o.sample.view_calibration_source,
                         "was learned with the 3D calibration '" + o.sample.view_calibration->landmark_calibration +
                             "', this run uses '" + used + "'",
                         "pass the same --landmark-calibration, or learn it again with --write-view-calibration");
    for (const ViewSpec& v : o.sample.views) o.sample.view_calibration->at(v.name, v.yaw_deg, o.sample.view_calibration_source);
  }
  // A whole folder from another template shows at its first subject; missing maps show for every subject up front:
  // a missing diffuse stops the run, other missing maps are filled (one warning names the subjects).
  std::string filled;
  for (const std::string& s : subjects) {
    try {
      check_subject_files(o.registered + "/" + s, o);
    } catch (const InvalidInput&) {
      if (!o.keep_going) throw;
      continue;
    }
    std::string names;
    for (const std::string& m : missing_maps(o.registered + "/" + s)) names += (names.empty() ? "" : ", ") + m;
    if (!names.empty()) filled += (filled.empty() ? "" : "; ") + s + " (" + names + ")";
  }
  if (!filled.empty())
    spdlog::warn("make-dataset: subjects without some maps; their targets are filled (normal flat, roughness {:.2f}, "
                 "specular {:.2f}) and their samples' JSON lists filled_maps: {}", kDefaultRoughness, kDefaultSpecular,
                 filled);
  for (const std::string& s : subjects) {
    if (find_scan_mesh(o.registered + "/" + s).empty()) continue;
    if (find_scan_map(o.registered + "/" + s, "diffuse").empty()) continue;
    try {
      load_subject_mesh(o.registered + "/" + s, model);
    } catch (const InvalidInput&) {
      if (!o.keep_going) throw;
    }
    break;
  }
  std::vector<int> photos;
  if (!o.celebamask.empty()) {
    photos = celebamask_ids(o.celebamask);
    if (int(photos.size()) > o.celebamask_count) photos.resize(size_t(o.celebamask_count));
  }

  // CelebAMask photos first: a photo without a face then stops a run before any subject's shard.
  std::vector<Unit> units;
  for (size_t i = 0; i < photos.size(); i += size_t(o.celebamask_per_shard)) {
    Unit u;
    u.id = int(units.size());
    u.photos.assign(photos.begin() + long(i), photos.begin() + long(std::min(photos.size(), i + size_t(o.celebamask_per_shard))));
    units.push_back(u);
  }
  const auto splits = split_subjects(int(subjects.size()), o.split, o.seed);
  for (int k = 0; k < 3; ++k) {
    report.split_subjects[size_t(k)] = int(splits[size_t(k)].size());
    for (size_t i = 0; i < splits[size_t(k)].size(); i += size_t(o.subjects_per_shard)) {
      Unit u;
      u.id = int(units.size());
      u.split = k;
      u.local = int(i) / o.subjects_per_shard;
      for (size_t j = i; j < std::min(splits[size_t(k)].size(), i + size_t(o.subjects_per_shard)); ++j)
        u.subjects.push_back(splits[size_t(k)][j]);
      units.push_back(u);
    }
  }
  report.units = int(units.size());
  make_directories(o.output);
  const json options_json = options_to_json(o);

  int64_t total = 0, done = 0;
  std::vector<const Unit*> todo;
  for (const Unit& u : units) {
    if (u.id % o.shards != o.shard) continue;
    ++report.units_mine;
    if (fs::exists(o.output + "/.index/" + numbered("unit", u.id) + ".json")) {
      ++report.units_resumed;
      continue;
    }
    todo.push_back(&u);
    total += int64_t(u.subjects.size() + u.photos.size());
  }
  LayoutRasters rasters(model.topology, o.sample.input_res);
  std::vector<std::string> order;
  for (const Unit* u : todo)
    for (int s : u->subjects) order.push_back(o.registered + "/" + subjects[size_t(s)]);
  BakeAhead bakes(std::move(order), rasters, o);
  for (const Unit* u : todo) {
    run_unit(*u, subjects, model, o, detect, detect_photo, rasters, bakes, report,
             [&](const std::string& item) { bareskin::report(progress, done++, total, item); });
    ++report.units_done;
  }
  bareskin::report(progress, done, total, "manifests");
  write_manifests(units, subjects, o, options_json, report);
  if (!o.write_view_calibration.empty() && report.complete)
    write_view_calibration(o.write_view_calibration, learn_view_calibration(report_files(o.output)));
  std::error_code ec;
  fs::remove(o.output + "/.tmp", ec);  // when empty (other workers may still use it)
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return report;
}

}  // namespace bareskin::texgen
