#include "texgen/faces.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <malloc.h>

#include "core/error.h"
#include "core/files.h"
#include "core/log.h"
#include "core/parallel.h"
#include "core/png.h"
#include "morphable/fit.h"
#include "texgen/face_render.h"
#include "texgen/makeup.h"

namespace bareskin::texgen {
namespace fs = std::filesystem;

const char* const kSplitNames[3] = {"train", "val", "test"};
constexpr int kSize = detect::kAlignedSize;
// The pre-alignment render ("the photo") has the canonical camera's focal length on a larger canvas, so the detector
// sees the face with some surroundings, as in a photo, not a tight crop.
constexpr int kPhotoSize = 384;

// ---- options and plan ----

void FacesOptions::check() const {
  if (model.empty()) throw InvalidInput("--model", "is required", "give the model.safetensors mm-build wrote");
  if (count <= 0) throw InvalidInput("--count", "must be at least 1 (got " + std::to_string(count) + ")", "e.g. --count 1000");
  if (mm_subjects < 0) throw InvalidInput("--mm-subjects", "must not be negative", "e.g. --mm-subjects 90");
  parse_skin_tones(skin_tones);
  if (!(val >= 0) || !(test >= 0)) throw InvalidInput("--val/--test", "must not be negative", "a count or a fraction");
  if (shard_size <= 0) throw InvalidInput("--shard-size", "must be positive", "e.g. --shard-size 100");
  if (shards < 1 || shard < 0 || shard >= shards)
    throw InvalidInput("--shard", std::to_string(shard) + " of " + std::to_string(shards) + " is not a worker",
                       "give 0 <= --shard < --shards");
  if (align != "detector" && align != "truth")
    throw InvalidInput("--align", "'" + align + "' is neither detector nor truth", "use --align detector|truth");
  const auto chosen = makeup::parse_styles(styles, "--styles");
  if (!exclude_styles.empty()) makeup::select_styles(chosen, makeup::parse_styles(exclude_styles, "--exclude-styles"));
  if (!(occluder_prob >= 0 && occluder_prob <= 1)) throw InvalidInput("--occluders", "is not a probability", "0..1");
  if (map_size < 32 || map_size > 4096) throw InvalidInput("--map-size", "must be in [32, 4096]", "e.g. --map-size 512");
  if (layer_size < 16 || (map_size % layer_size) != 0)
    throw InvalidInput("--layer-size", "must divide --map-size", "e.g. --map-size 512 --layer-size 256");
  const SampleRanges& r = ranges;
  for (double v : {r.yaw_max, r.pitch_max, r.roll_max})
    if (!(v >= 0 && v <= 90)) throw InvalidInput("--yaw-max/--pitch-max/--roll-max", "must be in [0, 90] degrees", "");
  if (!(r.expression_max >= 0 && r.expression_max <= 5))
    throw InvalidInput("--expression-max", "must be in [0, 5] standard deviations", "e.g. --expression-max 0.5");
  if (!(r.light_max >= 0 && r.light_max <= 2)) throw InvalidInput("--light-max", "must be in [0, 2]", "e.g. 0.6");
}

nlohmann::json FacesOptions::to_json() const {
  return {{"registered", registered},   {"model", model},
          {"count", count},             {"seed", seed},
          {"mm_subjects", mm_subjects}, {"skin_tones", skin_tones}, {"val", val},
          {"test", test},               {"shard_size", shard_size},
          {"align", align},             {"yaw_max", ranges.yaw_max},
          {"pitch_max", ranges.pitch_max}, {"roll_max", ranges.roll_max},
          {"expression_max", ranges.expression_max}, {"expression_prob", ranges.expression_prob},
          {"light_max", ranges.light_max}, {"specular_max", ranges.specular_max},
          {"occluders", occluder_prob}, {"styles", styles},
          {"exclude_styles", exclude_styles}, {"map_size", map_size}, {"layer_size", layer_size},
          {"size", kSize}};
}

int64_t FacesPlan::shards_in(int split, int64_t shard_size) const {
  return (int64_t(split_samples[size_t(split)].size()) + shard_size - 1) / shard_size;
}

namespace {
int subjects_for(double given, int total) {
  const int n = given < 1 ? int(std::lround(given * total)) : int(given);
  return std::min(n, total);
}
}  // namespace

FacesPlan plan_faces(const FacesOptions& o, const std::vector<std::string>& registered_ids) {
  FacesPlan p;
  p.subjects = registered_ids;
  for (int i = 0; i < o.mm_subjects; ++i) {
    char id[32];
    std::snprintf(id, sizeof(id), "mm/%06d", i);
    p.subjects.push_back(id);
  }
  const int S = int(p.subjects.size());
  if (S == 0) throw InvalidInput("--mm-subjects", "no subjects: no registered folder and no 3DMM subjects", "give --registered or --mm-subjects N");
  const int n_test = subjects_for(o.test, S), n_val = subjects_for(o.val, S);
  if (n_test + n_val >= S)
    throw InvalidInput("--val/--test", std::to_string(n_val) + " + " + std::to_string(n_test) + " of " +
                                           std::to_string(S) + " subjects leave none for training",
                       "give fewer validation/test subjects or more subjects (--mm-subjects)");
  // A seeded shuffle decides each subject's split; samples visit the subjects in another seeded order.
  std::vector<int> order(static_cast<size_t>(S));
  for (int i = 0; i < S; ++i) order[size_t(i)] = i;
  Rng rng(o.seed ^ 0x53706C6974ull);  // "Split"
  for (int i = S - 1; i > 0; --i) std::swap(order[size_t(i)], order[size_t(rng.below(i + 1))]);
  p.subject_split.assign(size_t(S), 0);
  for (int i = 0; i < n_test; ++i) p.subject_split[size_t(order[size_t(i)])] = 2;
  for (int i = n_test; i < n_test + n_val; ++i) p.subject_split[size_t(order[size_t(i)])] = 1;
  std::vector<int> visit(order.rbegin(), order.rend());
  p.split_samples.assign(3, {});
  p.sample_subject.resize(size_t(o.count));
  for (int64_t i = 0; i < o.count; ++i) {
    const int s = visit[size_t(i % S)];
    p.sample_subject[size_t(i)] = s;
    p.split_samples[size_t(p.subject_split[size_t(s)])].push_back(i);
  }
  return p;
}

nlohmann::json FacesReport::to_json() const {
  nlohmann::json j = {{"samples_written", samples_written}, {"shards_written", shards_written},
                      {"shards_skipped", shards_skipped},   {"complete_splits", complete_splits},
                      {"seconds", seconds},
                      {"samples_per_second", seconds > 0 ? double(samples_written) / seconds : 0.0}};
  if (detector_runs) j["detector"] = {{"runs", detector_runs}, {"detected", detected}, {"seconds", detector_seconds}};
  j["stage_cpu_seconds"] = stage_seconds;
  return j;
}

// ---- the world ----

// CPU seconds per stage over all threads (report.json), to see where a sample's time goes.
enum StageId { kSubject, kMakeup, kBackground, kPhoto, kRender, kShade, kEncode, kStageCount };
const char* const kStageNames[kStageCount] = {"subject", "makeup", "background", "photo", "rasterize", "shade", "encode"};
struct StageClock {
  mutable std::atomic<int64_t> ns[kStageCount] = {};
  struct Scope {
    const StageClock& clock;
    StageId id;
    std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
    ~Scope() {
      clock.ns[id] += std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - t0).count();
    }
  };
  Scope time(StageId id) const { return Scope{*this, id}; }
  // The time since t0 into `id`; returns now (the next stage's t0).
  std::chrono::steady_clock::time_point lap(StageId id, std::chrono::steady_clock::time_point t0) const {
    const auto now = std::chrono::steady_clock::now();
    ns[id] += std::chrono::duration_cast<std::chrono::nanoseconds>(now - t0).count();
    return now;
  }
  nlohmann::json to_json() const {
    nlohmann::json j;
    for (int i = 0; i < kStageCount; ++i) j[kStageNames[i]] = double(ns[i]) * 1e-9;
    return j;
  }
};

struct FaceGenerator::World {
  FacesOptions opt;
  MorphableModel model;
  RegisteredSubjects registered;
  std::vector<BackgroundPhoto> photos;
  FacesPlan plan;
  Camera camera = view_camera("front", kSize, Eigen::Vector3d::Zero(), 1000);
  Camera photo_camera = [] {
    Camera c = view_camera("front", kSize, Eigen::Vector3d::Zero(), 1000);
    c.width = c.height = kPhotoSize;
    c.cx = c.cy = kPhotoSize / 2.0;
    return c;
  }();
  makeup::MakeupRegions regions;      // at map_size, from the model's topology and landmark vertices
  std::vector<uint8_t> skin_uv;       // map_size²: 1 = skin (the foundation region: not eyes, brows, lips, nostrils)
  std::vector<makeup::MakeupStyle> styles_train, styles_test;  // test also draws the excluded family
  StageClock clock;

  // One sample between the pre-alignment render ("the photo") and the aligned render.
  struct Stage {
    int64_t index = 0;
    int split = 0;
    std::shared_ptr<const FaceSubject> subject;
    SampleParams params;
    std::string style = "none";
    makeup::MakeupLook look;
    makeup::MakeupLayer layer;
    std::shared_ptr<const Image> makeup_diffuse, makeup_roughness, makeup_specular;  // the maps with makeup
    Eigen::Vector3f skin_tone;  // the bare albedo's mean over the foundation region
    Eigen::Vector3d photo_translation;
    Eigen::MatrixX3d shape;  // neutral + expression, model frame
    detect::Landmarks68 photo_truth;
    Occluders photo_occluders;
    Image photo_background;
    std::string background_kind;
    Image photo_srgb;  // --align detector
    std::vector<detect::PhotoFace> detected;
  };

  Mesh posed(const Stage& s, const Eigen::Vector3d& translation) const {
    Mesh m = model.topology;
    m.V = ((s.shape * euler_rotation(s.params.rotation).transpose()).rowwise() + translation.transpose()).eval();
    m.N.resize(0, 3);
    return m;
  }

  detect::Landmarks68 project_landmarks(const Mesh& m, const Camera& cam) const {
    detect::Landmarks68 lm;
    for (int i = 0; i < 68; ++i)
      lm.row(i) = cam.project(m.V.row(model.landmark_vertices[size_t(i)]).transpose()).head<2>().transpose();
    return lm;
  }

  std::shared_ptr<const FaceSubject> subject(int s) const {
    const int n_scans = int(registered.subjects.size());
    if (s < n_scans) return std::shared_ptr<const FaceSubject>(&registered.subjects[size_t(s)], [](const FaceSubject*) {});
    return std::make_shared<const FaceSubject>(
        model_subject(model, registered, opt.seed, s - n_scans, parse_skin_tones(opt.skin_tones)));
  }

  // The lit picture: background, face, occluders (linear).
  Image picture(const Surface& surface, const SurfaceMaps& maps, const Light& light, const Image& background,
                const Occluders& occluders) const {
    Image out = background;
    shade(surface, maps, light, out);
    paint_occluders(occluders, out);
    return out;
  }

  void apply_look(Stage& s, Rng& rng) const;
  Stage prepare(int64_t index) const;
  shards::Sample finish(Stage& stage) const;
};

namespace {

Image encode_srgb(const Image& linear) {
  Image out(linear.width, linear.height, linear.channels, ColorSpace::sRGB);
  for (size_t i = 0; i < out.pixels.size(); ++i) out.pixels[i] = linear_to_srgb(std::clamp(linear.pixels[i], 0.f, 1.f));
  return out;
}

// The summed layer at size² for storage: premultiplied colour and alpha averaged over each block, then straight again.
makeup::MakeupLayer stored_layer(const makeup::MakeupLayer& layer, int size) {
  if (layer.colour.width == size) return layer;
  Image pre = layer.colour;
  for (size_t i = 0; i < pre.pixels.size(); i += 4)
    for (int k = 0; k < 3; ++k) pre.pixels[i + size_t(k)] *= pre.pixels[i + 3];
  makeup::MakeupLayer out;
  out.colour = resample_map(pre, size);
  out.finish = resample_map(layer.finish, size);
  for (size_t i = 0; i < out.colour.pixels.size(); i += 4) {
    const float a = out.colour.pixels[i + 3];
    for (int k = 0; k < 3; ++k) out.colour.pixels[i + size_t(k)] = a > 0 ? std::min(1.f, out.colour.pixels[i + size_t(k)] / a) : 0.f;
  }
  return out;
}

nlohmann::json vec_json(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

// The detected face that is ours: the best-scoring one whose eyes, nose and mouth lie within a third of the eye
// distance of the truth's (a detection elsewhere, e.g. in a background photo, is not our face: not detected).
const detect::PhotoFace* ours(const std::vector<detect::PhotoFace>& faces, const detect::Landmarks68& truth) {
  const detect::FivePoints t = detect::five_points(truth);
  const double eyes = (t.row(1) - t.row(0)).norm();
  for (const detect::PhotoFace& f : faces) {
    if (!f.points.allFinite()) continue;
    const detect::FivePoints p = detect::five_points(f.points);
    if ((p - t).rowwise().norm().maxCoeff() < eyes / 3) return &f;
  }
  return nullptr;
}

}  // namespace

// The sample's makeup: a style from its split's pool, a look, its summed layer, and the subject's maps with it.
void FaceGenerator::World::apply_look(Stage& s, Rng& rng) const {
  std::mt19937_64 mt(rng.next());
  const makeup::MakeupStyle style = makeup::sample_style(s.split == 2 ? styles_test : styles_train, mt);
  s.look = makeup::sample_look(style, mt);
  s.style = makeup::to_string(style);
  const FaceSubject& subj = *s.subject;
  const int n = regions.uv_size;
  s.skin_tone = makeup::skin_tone(regions, *subj.diffuse);
  if (s.look.layers.empty()) {
    s.layer.colour = Image(n, n, 4, ColorSpace::Linear);
    s.layer.finish = Image(n, n, 2, ColorSpace::Data);
    s.makeup_diffuse = subj.diffuse;
    s.makeup_roughness = subj.roughness;
    s.makeup_specular = subj.specular;
    return;
  }
  s.layer = makeup::paint(regions, s.look, s.skin_tone);
  auto diffuse = std::make_shared<Image>(resample_map(*subj.diffuse, n));
  auto roughness = std::make_shared<Image>(resample_map(*subj.roughness, n));
  auto specular = std::make_shared<Image>(resample_map(*subj.specular, n));
  makeup::apply_makeup(s.layer, *diffuse, roughness.get(), specular.get());
  s.makeup_diffuse = diffuse;
  s.makeup_roughness = roughness;
  s.makeup_specular = specular;
}

FaceGenerator::World::Stage FaceGenerator::World::prepare(int64_t index) const {
  Stage s;
  s.index = index;
  const int subject_index = plan.sample_subject[size_t(index)];
  s.split = plan.subject_split[size_t(subject_index)];
  Rng rng(opt.seed, uint64_t(index));
  {
    auto t = clock.time(kSubject);
    s.subject = subject(subject_index);
    s.params = draw_params(model, opt.ranges, rng);
    s.shape = s.subject->shape;
    if (s.params.beta.size() && s.params.beta.cwiseAbs().maxCoeff() > 0)
      s.shape += model.shape(Eigen::VectorXd(), s.params.beta) - model.topology.V;
  }
  {
    auto t = clock.time(kMakeup);
    apply_look(s, rng);
  }
  s.photo_translation = s.params.jitter;
  {
    auto t = clock.time(kBackground);
    s.photo_background = make_background(kPhotoSize, photos, rng, &s.background_kind);
  }
  auto t_photo = clock.time(kPhoto);
  {  // the photo's truth landmarks: only the 68 landmark vertices posed (posed() does the same for all of them)
    const Eigen::Matrix3d R = euler_rotation(s.params.rotation);
    for (int i = 0; i < 68; ++i) {
      const Eigen::RowVector3d v = s.shape.row(model.landmark_vertices[size_t(i)]) * R.transpose();
      s.photo_truth.row(i) = photo_camera.project(v.transpose() + s.photo_translation).head<2>().transpose();
    }
  }
  std::vector<Eigen::Vector2d> lm(68);
  for (int i = 0; i < 68; ++i) lm[size_t(i)] = s.photo_truth.row(i).transpose();
  s.photo_occluders = draw_occluders(kPhotoSize, lm, opt.occluder_prob, rng);
  {
    auto t = clock.time(kBackground);
    const Eigen::Vector3f skin = s.skin_tone * float(s.params.light.ambient * 0.886 + 0.5 * s.params.light.strength);
    paint_head(s.photo_background, lm, skin, s.photo_occluders.hair, rng);
  }
  if (opt.align == "detector") {
    const Surface surface = rasterize_face(posed(s, s.photo_translation), photo_camera);
    const SurfaceMaps maps{s.makeup_diffuse.get(), s.makeup_roughness.get(), s.makeup_specular.get()};
    s.photo_srgb = encode_srgb(picture(surface, maps, s.params.light, s.photo_background, s.photo_occluders));
  }
  return s;
}

shards::Sample FaceGenerator::World::finish(Stage& s) const {
  // Alignment as a real photo gets it: the detector's landmarks (or the truth), 5 points, scale + translation.
  std::string source = "truth";
  double score = 0, detector_error = -1;
  detect::Similarity sim;
  const detect::PhotoFace* found = ours(s.detected, s.photo_truth);
  if (found) {
    sim = detect::alignment(found->points);
    source = "detector";
    score = found->score;
    std::vector<double> err(68);
    for (int i = 0; i < 68; ++i) err[size_t(i)] = (found->points.row(i) - s.photo_truth.row(i)).norm() * sim.scale;
    std::nth_element(err.begin(), err.begin() + 34, err.end());
    detector_error = err[34];
  } else {
    sim = detect::alignment(s.photo_truth);  // with --align detector: it found no face ("detected": false)
  }
  // Move the head so the canonical camera sees the aligned view: scale → depth, shift → x/y.
  const double f = camera.focal, c = camera.cx;
  const Eigen::Vector3d& T0 = s.photo_translation;
  const double D0 = 1000 - T0.z(), D1 = D0 / sim.scale;
  const Eigen::Vector2d centre0(photo_camera.cx + f * T0.x() / D0, photo_camera.cy - f * T0.y() / D0);
  const Eigen::Vector2d centre1 = sim.apply(centre0);
  const Eigen::Vector3d T1((centre1.x() - c) * D1 / f, -(centre1.y() - camera.cy) * D1 / f, 1000 - D1);

  auto lap = std::chrono::steady_clock::now();
  const Mesh mesh = posed(s, T1);
  const Surface surface = rasterize_face(mesh, camera);
  lap = clock.lap(kRender, lap);
  const Occluders occluders = warp_occluders(s.photo_occluders, sim, kSize);
  const Image background = detect::warp_aligned(s.photo_background, sim, kSize);
  const FaceSubject& subj = *s.subject;
  const SurfaceMaps bare_maps{subj.diffuse.get(), subj.roughness.get(), subj.specular.get()};
  const Image before = picture(surface, bare_maps, s.params.light, background, occluders);
  const SurfaceMaps makeup_maps{s.makeup_diffuse.get(), s.makeup_roughness.get(), s.makeup_specular.get()};
  const Image makeup = s.look.layers.empty() ? before : picture(surface, makeup_maps, s.params.light, background, occluders);
  const Image bare = sample_map(surface, *subj.diffuse);

  // Masks and landmarks.
  const size_t n = size_t(kSize) * kSize;
  Image face(kSize, kSize, 1, ColorSpace::Data), skin(kSize, kSize, 1, ColorSpace::Data);
  for (size_t i = 0; i < n; ++i) {
    if (!surface.covered(i) || occluders.labels.label[i]) continue;
    face.pixels[i] = 1;
    const int un = regions.uv_size;
    const int tx = std::clamp(int(surface.uv[2 * i] * un), 0, un - 1);
    const int ty = std::clamp(int((1 - surface.uv[2 * i + 1]) * un), 0, un - 1);
    skin.pixels[i] = skin_uv[size_t(ty) * un + tx] ? 1.f : 0.f;
  }
  const detect::Landmarks68 landmarks = project_landmarks(mesh, camera);
  nlohmann::json lm_json = nlohmann::json::array(), visible = nlohmann::json::array();
  for (int i = 0; i < 68; ++i) {
    const Eigen::Vector3d p = camera.project(mesh.V.row(model.landmark_vertices[size_t(i)]).transpose());
    const int x = int(std::floor(p.x())), y = int(std::floor(p.y()));
    bool seen = x >= 0 && y >= 0 && x < kSize && y < kSize;
    if (seen) {
      const size_t k = size_t(y) * kSize + size_t(x);
      seen = surface.covered(k) && p.z() <= surface.raster.depth[k] + 2.0 && !occluders.labels.label[k];
    }
    lm_json.push_back({landmarks(i, 0), landmarks(i, 1)});
    visible.push_back(seen);
  }

  nlohmann::json align = {{"similarity", {{sim.scale, 0.0, sim.translation.x()}, {0.0, sim.scale, sim.translation.y()}}},
                          {"source", source}};
  if (opt.align == "detector") {
    align["detected"] = found != nullptr;
    align["detector_faces"] = s.detected.size();
    if (found) {
      align["detector_score"] = score;
      align["detector_landmark_error_px"] = detector_error;  // median over 68, aligned pixels
    }
  }
  nlohmann::json truth = {{"frame", subj.frame}, {"maps", subj.maps}};
  if (!subj.filled_maps.empty()) truth["filled_maps"] = subj.filled_maps;
  if (subj.scan)
    truth.update({{"alpha_delta", "least-squares projections of the scan onto the model"},
                  {"shape_residual_mm", subj.shape_residual_mm},
                  {"appearance_residual", subj.appearance_residual}});
  nlohmann::json meta = {
      {"subject", subj.id},
      {"split", kSplitNames[s.split]},
      {"style", s.style},
      {"makeup", makeup::to_json(s.look)},
      {"layer_size", std::min(opt.layer_size, regions.uv_size)},
      {"landmarks", lm_json},
      {"landmarks_visible", visible},
      {"coefficients",
       {{"alpha", vec_json(subj.alpha)},
        {"beta", vec_json(s.params.beta)},
        {"delta", vec_json(subj.delta)},
        {"rotation", vec_json(s.params.rotation)},
        {"translation", vec_json(T1)},
        {"gamma", s.params.light.gamma}}},
      {"camera", {{"focal", camera.focal}, {"cx", camera.cx}, {"cy", camera.cy}, {"width", kSize}, {"height", kSize}}},
      {"align", align},
      {"light", s.params.light.to_json()},
      {"background", s.background_kind},
      {"occluders", s.photo_occluders.kinds},
      {"subject_truth", truth},
      {"has_truth", true},
  };
  lap = clock.lap(kShade, lap);
  auto t_encode = clock.time(kEncode);
  shards::Sample out;
  char key[16];
  std::snprintf(key, sizeof(key), "%08lld", static_cast<long long>(s.index));
  out.key = key;
  out.members["makeup.png"] = encode_png(encode_srgb(makeup));
  out.members["before.png"] = encode_png(encode_srgb(before));
  out.members["bare.png"] = encode_png(encode_srgb(bare));
  out.members["skin.png"] = encode_png(skin);
  out.members["face.png"] = encode_png(face);
  const makeup::MakeupLayer layer = stored_layer(s.layer, std::min(opt.layer_size, regions.uv_size));
  out.members["layer.png"] = encode_png(makeup::layer_png_image(layer));
  out.members["finish.png"] = encode_png(makeup::finish_png_image(layer));
  out.members["json"] = meta.dump(1);
  return out;
}

// ---- the generator ----

FaceGenerator::FaceGenerator(FacesOptions options) : world_(std::make_unique<World>()) {
  World& w = *world_;
  options.check();
  w.opt = std::move(options);
  w.model = read_model(w.opt.model);
  if (w.model.landmark_vertices.size() != 68)
    throw InvalidInput(w.opt.model, "has no 68 landmark vertices", "rebuild it with mm-build");
  w.registered = read_registered_subjects(w.opt.registered, w.model, w.opt.map_size);
  w.photos = read_background_photos(w.opt.backgrounds);
  std::vector<std::string> ids;
  for (const FaceSubject& s : w.registered.subjects) ids.push_back(s.id);
  w.plan = plan_faces(w.opt, ids);
  // Makeup regions on the model's topology (the template's) and the skin in UV.
  TemplateFace face;
  face.mesh = w.model.topology;
  face.landmark_vertices = w.model.landmark_vertices;
  w.regions = makeup::makeup_regions(face, w.opt.map_size);
  const int n = w.regions.uv_size;
  w.skin_uv.assign(size_t(n) * n, 0);
  const Image& foundation = w.regions[makeup::Region::Face];
  for (size_t i = 0; i < w.skin_uv.size(); ++i)
    w.skin_uv[i] = foundation.pixels[i] < 0 && w.regions.coverage.pixels[i] > 0 && w.regions.exclusion.pixels[i] <= 0;
  const auto styles = makeup::parse_styles(w.opt.styles, "--styles");
  w.styles_test = styles;
  w.styles_train = w.opt.exclude_styles.empty()
                       ? styles
                       : makeup::select_styles(styles, makeup::parse_styles(w.opt.exclude_styles, "--exclude-styles"));
}

FaceGenerator::~FaceGenerator() = default;

const FacesPlan& FaceGenerator::plan() const { return world_->plan; }

shards::Sample FaceGenerator::render(int64_t index, const detect::PhotoDetector& detector) const {
  if (index < 0 || index >= world_->opt.count) throw InvalidInput("", "sample index out of range", "");
  World::Stage s = world_->prepare(index);
  if (!s.photo_srgb.empty() && detector) s.detected = detector(s.photo_srgb);
  return world_->finish(s);
}

namespace {
std::string shard_name(int64_t k) {
  char name[32];
  std::snprintf(name, sizeof(name), "faces-%06lld.tar", static_cast<long long>(k));
  return name;
}
}  // namespace

FacesReport FaceGenerator::run(const detect::PhotoDetector& detector, const ProgressCallback& progress) {
  const World& w = *world_;
  const auto t0 = std::chrono::steady_clock::now();
  FacesReport out;
  const int64_t size = w.opt.shard_size;
  struct Job {
    int split;
    int64_t shard;
  };
  std::vector<Job> jobs, mine;
  for (int split = 0; split < 3; ++split)
    for (int64_t k = 0; k < w.plan.shards_in(split, size); ++k) jobs.push_back({split, k});
  int64_t total = 0;
  for (size_t j = 0; j < jobs.size(); ++j)
    if (int(j % size_t(w.opt.shards)) == w.opt.shard) {
      mine.push_back(jobs[j]);
      const auto& list = w.plan.split_samples[size_t(jobs[j].split)];
      total += std::min<int64_t>(size, int64_t(list.size()) - jobs[j].shard * size);
    }
  for (int split = 0; split < 3; ++split) make_directories(w.opt.output + "/" + kSplitNames[split]);
  int64_t done = 0;
  report(progress, 0, total, "faces");
  for (const Job& job : mine) {
    const fs::path dir = fs::path(w.opt.output) / kSplitNames[job.split];
    const std::string name = shard_name(job.shard);
    const auto& list = w.plan.split_samples[size_t(job.split)];
    const int64_t begin = job.shard * size, end = std::min<int64_t>(begin + size, int64_t(list.size()));
    if (fs::exists(dir / name)) {  // written whole (renamed into place when complete): a resumed run keeps it
      ++out.shards_skipped;
      done += end - begin;
      report(progress, done, total, "faces");
      continue;
    }
    std::vector<shards::Sample> samples(size_t(end - begin));
    constexpr int64_t kBatch = 16;
    for (int64_t b = begin; b < end; b += kBatch) {
      const int64_t e = std::min(b + kBatch, end);
      std::vector<World::Stage> stages(size_t(e - b));
      parallel_for(b, e, [&](int64_t lo, int64_t hi) {
        for (int64_t i = lo; i < hi; ++i) stages[size_t(i - b)] = w.prepare(list[size_t(i)]);
      });
      for (auto& s : stages) {  // the detector runs on the Torch side's own threads, one photo at a time
        if (s.photo_srgb.empty() || !detector) continue;
        const auto td = std::chrono::steady_clock::now();
        s.detected = detector(s.photo_srgb);
        out.detector_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - td).count();
        ++out.detector_runs;
        out.detected += ours(s.detected, s.photo_truth) != nullptr;
      }
      parallel_for(b, e, [&](int64_t lo, int64_t hi) {
        for (int64_t i = lo; i < hi; ++i) samples[size_t(i - begin)] = w.finish(stages[size_t(i - b)]);
      });
      done += e - b;
      report(progress, done, total, "faces");
    }
    // Written into a hidden folder of this process beside the split (never committed: the scratch goes when it leaves
    // scope, a killed run's is removed by the next run), then the shard is renamed into place: a kill leaves no partial
    // shard, and two runs over the same output never write into each other's files.
    const AtomicDirectory scratch((dir / name).string());
    {
      shards::ShardWriter writer(scratch.path(), "faces", int64_t(samples.size()) + 1);
      for (const auto& s : samples) writer.write(s);
      writer.finish();
    }
    fs::rename(fs::path(scratch.path()) / "faces-000000.tar", dir / name);
    ++out.shards_written;
    out.samples_written += int64_t(samples.size());
  }
  // Manifests of the splits whose shards are all there (the last worker to finish a split writes it).
  for (int split = 0; split < 3; ++split) {
    const fs::path dir = fs::path(w.opt.output) / kSplitNames[split];
    shards::Manifest m;
    bool complete = true;
    const auto& list = w.plan.split_samples[size_t(split)];
    for (int64_t k = 0; k < w.plan.shards_in(split, size) && complete; ++k) {
      const fs::path p = dir / shard_name(k);
      if (!fs::exists(p)) {
        complete = false;
        break;
      }
      shards::ShardInfo info;
      info.name = shard_name(k);
      info.samples = std::min<int64_t>(size, int64_t(list.size()) - k * size);
      info.crc32 = shards::file_crc32(p.string());
      info.bytes = int64_t(fs::file_size(p));
      m.shards.push_back(info);
    }
    if (!complete) continue;
    std::vector<std::string> subjects;
    for (size_t s = 0; s < w.plan.subjects.size(); ++s)
      if (w.plan.subject_split[s] == split) subjects.push_back(w.plan.subjects[s]);
    m.metadata = {{"generator", w.opt.generator}, {"kind", "faces"},          {"split", kSplitNames[split]},
                  {"samples", int64_t(list.size())}, {"subjects", subjects}, {"config", w.opt.to_json()},
                  {"members", {"makeup.png", "before.png", "bare.png", "skin.png", "face.png", "layer.png",
                               "finish.png", "json"}}};
    shards::write_manifest(dir.string(), m);
    out.complete_splits.push_back(kSplitNames[split]);
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  out.stage_seconds = w.clock.to_json();
  return out;
}

FacesReport write_faces(const FacesOptions& options, const detect::PhotoDetector& detector,
                        const ProgressCallback& progress) {
  options.check();
  // Every sample allocates and frees images of a few MB: keep them in the heap instead of fresh zeroed pages from the
  // kernel each time (glibc returns blocks above 128 KB to the system at once: bench/BENCHMARKS.md, texgen faces).
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 512 << 20);
  FaceGenerator generator(options);  // reads and checks every input before anything is written
  make_directories(options.output);
  const FacesReport report = generator.run(detector, progress);
  const std::string suffix = options.shards > 1 ? "-" + std::to_string(options.shard) : "";
  write_file_atomic(options.output + "/report" + suffix + ".json", report.to_json().dump(1) + "\n");
  return report;
}

}  // namespace bareskin::texgen
