#include "texgen/face_world.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <spdlog/spdlog.h>

#include "core/error.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "core/scan_folder.h"
#include "core/similarity.h"
#include "render/sh.h"
#include "texgen/makeup.h"

namespace bareskin::texgen {
namespace fs = std::filesystem;

// ---- random numbers ----

namespace {
uint64_t splitmix64(uint64_t& x) {
  uint64_t z = (x += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}
uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
}  // namespace

Rng::Rng(uint64_t seed) {
  for (auto& s : s_) s = splitmix64(seed);
}

Rng::Rng(uint64_t seed, uint64_t index) {
  uint64_t x = seed;
  const uint64_t a = splitmix64(x);
  uint64_t y = a ^ (index * 0xD1B54A32D192ED03ull);
  for (auto& s : s_) s = splitmix64(y);
}

uint64_t Rng::next() {
  const uint64_t result = rotl(s_[1] * 5, 7) * 9, t = s_[1] << 17;
  s_[2] ^= s_[0];
  s_[3] ^= s_[1];
  s_[1] ^= s_[2];
  s_[0] ^= s_[3];
  s_[2] ^= t;
  s_[3] = rotl(s_[3], 45);
  return result;
}

double Rng::uniform() { return double(next() >> 11) * 0x1.0p-53; }

double Rng::normal() {
  const double u = 1.0 - uniform(), v = uniform();  // u in (0, 1]
  return std::sqrt(-2.0 * std::log(u)) * std::cos(2 * M_PI * v);
}

int Rng::below(int n) { return int(uniform() * n); }

// ---- subjects ----

namespace {

// Area average to size² (integer factors), or bilinear when the factor is not whole.
Image resample(const Image& in, int size) {
  if (in.width == size && in.height == size) return in;
  if (in.width == 1 && in.height == 1) {
    Image out(size, size, in.channels, in.color_space);
    for (size_t i = 0; i < out.pixels.size(); ++i) out.pixels[i] = in.pixels[i % size_t(in.channels)];
    return out;
  }
  Image out(size, size, in.channels, in.color_space);
  if (in.width % size == 0 && in.height % size == 0) {
    const int fx = in.width / size, fy = in.height / size;
    const float w = 1.f / float(fx * fy);
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x)
        for (int c = 0; c < in.channels; ++c) {
          float s = 0;
          for (int j = 0; j < fy; ++j)
            for (int i = 0; i < fx; ++i) s += in.at(x * fx + i, y * fy + j, c);
          out.at(x, y, c) = s * w;
        }
    return out;
  }
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      const double sx = std::clamp((x + 0.5) * in.width / size - 0.5, 0.0, in.width - 1.0);
      const double sy = std::clamp((y + 0.5) * in.height / size - 0.5, 0.0, in.height - 1.0);
      const int x0 = int(sx), y0 = int(sy), x1 = std::min(x0 + 1, in.width - 1), y1 = std::min(y0 + 1, in.height - 1);
      const float ax = float(sx - x0), ay = float(sy - y0);
      for (int c = 0; c < in.channels; ++c)
        out.at(x, y, c) = (1 - ay) * ((1 - ax) * in.at(x0, y0, c) + ax * in.at(x1, y0, c)) +
                          ay * ((1 - ax) * in.at(x0, y1, c) + ax * in.at(x1, y1, c));
    }
  return out;
}

std::shared_ptr<const Image> read_map(const fs::path& dir, const std::string& name, bool colour, int size) {
  const std::string path = find_scan_map(dir.string(), name);
  if (path.empty())
    throw InvalidInput(dir.string(), "has no " + name + " map (" + name + ".png|exr|tif)",
                       "register the scan with its diffuse map (roughness and specular may be missing)");
  Image img = read_image(path);
  if (colour) {
    if (img.channels < 3) throw InvalidInput(path, "is not an RGB map", "give the diffuse albedo as RGB");
    if (img.color_space == ColorSpace::sRGB) img = to_linear(img);
    if (img.channels > 3) {
      Image rgb(img.width, img.height, 3, img.color_space);
      for (size_t i = 0; i < size_t(img.width) * img.height; ++i)
        for (int c = 0; c < 3; ++c) rgb.pixels[3 * i + c] = img.pixels[i * img.channels + c];
      img = std::move(rgb);
    }
  } else if (img.channels != 1) {
    Image grey(img.width, img.height, 1, ColorSpace::Data);
    for (size_t i = 0; i < grey.pixels.size(); ++i) grey.pixels[i] = img.pixels[i * img.channels];
    img = std::move(grey);
  }
  if (!colour) img.color_space = ColorSpace::Data;
  return std::make_shared<const Image>(resample(img, size));
}

// Least-squares standardised coefficients of x − mean on an orthonormal basis (rows) with standard deviations.
Eigen::VectorXd project(const RowMatrixXf& basis, const Eigen::VectorXf& stddev, const Eigen::VectorXd& centred,
                        double* residual_rms, int group) {
  const Eigen::VectorXd w = basis.cast<double>() * centred;
  Eigen::VectorXd coeff(w.size());
  for (int k = 0; k < w.size(); ++k) coeff[k] = w[k] / double(stddev[k]);
  const Eigen::VectorXd rest = centred - basis.cast<double>().transpose() * w;
  // RMS over groups (vertices: 3 numbers each; texels: 3 channels each).
  *residual_rms = std::sqrt(rest.squaredNorm() / std::max<double>(1, double(centred.size()) / group));
  return coeff;
}

// The mean of the subjects' roughness (or specular) maps over those that have one; null when none has.
std::shared_ptr<const Image> mean_map(const std::vector<FaceSubject>& subjects, bool roughness) {
  std::shared_ptr<Image> out;
  int n = 0;
  for (const FaceSubject& s : subjects) {
    const auto& m = roughness ? s.roughness : s.specular;
    if (!m) continue;
    if (!out) {
      out = std::make_shared<Image>(*m);
    } else {
      for (size_t i = 0; i < out->pixels.size(); ++i) out->pixels[i] += m->pixels[i];
    }
    ++n;
  }
  if (out)
    for (float& v : out->pixels) v /= float(n);
  return out;
}

// A registered subject's map that is missing (diffuse-only scans): the population mean, else the constant 3DMM subjects
// get without registered maps.
std::shared_ptr<const Image> fill_map(const std::shared_ptr<const Image>& mean, float constant) {
  return mean ? mean : std::make_shared<const Image>(1, 1, 1, ColorSpace::Data, constant);
}

}  // namespace

Image resample_map(const Image& map, int size) { return resample(map, size); }

RegisteredSubjects read_registered_subjects(const std::string& folder, const MorphableModel& model, int map_size) {
  RegisteredSubjects out;
  if (folder.empty()) return out;
  if (!fs::is_directory(folder))
    throw InvalidInput(folder, "is not a folder", "give the output folder of 'scan register' (--registered)");
  std::vector<fs::path> dirs;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_directory() && (fs::exists(e.path() / "mesh.ply") || fs::exists(e.path() / "mesh.obj")))
      dirs.push_back(e.path());
  std::sort(dirs.begin(), dirs.end());
  if (dirs.empty())
    throw InvalidInput(folder, "holds no registered subject (no */mesh.ply)", "give the output folder of 'scan register'");
  const Eigen::VectorXd mean_app = model.appearance_mean.cast<double>();
  for (const fs::path& dir : dirs) {
    FaceSubject s;
    const std::string name = dir.filename().string();
    s.id = "scan/" + name;
    s.scan = true;
    s.diffuse = read_map(dir, "diffuse", true, map_size);
    for (const char* m : {"roughness", "specular"}) {  // diffuse-only scans: filled below from the others
      if (find_scan_map(dir.string(), m).empty()) {
        s.filled_maps.push_back(m);
        continue;
      }
      (std::string(m) == "roughness" ? s.roughness : s.specular) = read_map(dir, m, false, map_size);
    }
    s.maps = "registered scan maps (diffuse, roughness, specular) at " + std::to_string(map_size) + "²";
    const std::string mesh_path = fs::exists(dir / "mesh.ply") ? (dir / "mesh.ply").string() : (dir / "mesh.obj").string();
    const Mesh mesh = read_mesh(mesh_path);
    if (mesh.V.rows() != model.vertices())
      throw InvalidInput(mesh_path, "has " + std::to_string(mesh.V.rows()) + " vertices, the model " +
                                        std::to_string(model.vertices()),
                         "register the scans to the template the model was built from");
    const auto it = std::find(model.subjects.begin(), model.subjects.end(), name);
    Eigen::Matrix4d T;
    if (it != model.subjects.end() && size_t(it - model.subjects.begin()) < model.procrustes.size()) {
      T = model.procrustes[size_t(it - model.subjects.begin())];
      s.frame = "the model's procrustes entry";
    } else {  // a subject the model was not built from: a rigid fit to the mean shape
      T = Eigen::umeyama(mesh.V.transpose(), model.topology.V.transpose(), false);
      s.frame = "rigid fit to the model's mean shape (not a training subject of the model)";
    }
    s.shape = transformed(T, mesh.V);
    const Eigen::MatrixX3d centred = s.shape - model.topology.V;
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> rows = centred;
    const Eigen::Map<const Eigen::VectorXd> flat(rows.data(), rows.size());
    s.alpha = project(model.shape_basis, model.shape_stddev, flat, &s.shape_residual_mm, 3);
    if (model.appearance_resolution > 0) {
      const Image diffuse_r = resample(*s.diffuse, model.appearance_resolution);
      Eigen::VectorXd a(mean_app.size());
      for (int64_t i = 0; i < a.size(); ++i) a[i] = diffuse_r.pixels[size_t(i)] - mean_app[i];
      for (size_t t = 0; t < model.appearance_mask.size(); ++t)  // texels the model does not model do not count
        if (!model.appearance_mask[t]) a.segment(3 * int64_t(t), 3).setZero();
      s.delta = project(model.appearance_basis, model.appearance_stddev, a, &s.appearance_residual, 3);
    }
    out.subjects.push_back(std::move(s));
  }
  out.mean_roughness = mean_map(out.subjects, true);
  out.mean_specular = mean_map(out.subjects, false);
  std::string filled;
  for (FaceSubject& s : out.subjects) {
    if (s.filled_maps.empty()) continue;
    std::string how, names;
    for (const std::string& m : s.filled_maps) {
      const bool r = m == "roughness";
      const auto& mean = r ? out.mean_roughness : out.mean_specular;
      const float constant = r ? kDefaultRoughness : kDefaultSpecular;
      (r ? s.roughness : s.specular) = fill_map(mean, constant);
      how += (how.empty() ? "" : ", ") + m +
             (mean ? " (mean of the registered subjects' maps)" : " " + std::to_string(constant) + " (none has one)");
      names += (names.empty() ? "" : ", ") + m;
    }
    s.maps = "registered scan maps (diffuse) at " + std::to_string(map_size) + "²; filled: " + how;
    filled += (filled.empty() ? "" : "; ") + s.id.substr(5) + " (" + names + ")";
  }
  if (!filled.empty())
    spdlog::warn("{}: subjects without roughness or specular maps, filled from the population mean (or the 3DMM "
                 "subjects' constants) and recorded as filled_maps in their samples: {}", folder, filled);
  return out;
}

double typology_angle(const Eigen::Vector3f& linear_rgb) {
  const Eigen::Vector3f lab = makeup::linear_rgb_to_lab(linear_rgb);
  return std::atan2(double(lab.x()) - 50, double(lab.z())) * 180 / M_PI;
}

namespace {
constexpr double kGroupFloor[kSkinToneGroups - 1] = {55, 41, 28, 10, -30};  // each group's lowest angle
}  // namespace

int skin_tone_group(double ita_degrees) {
  int g = 0;
  while (g < kSkinToneGroups - 1 && ita_degrees < kGroupFloor[g]) ++g;
  return g;
}

const char* skin_tone_group_name(int group) {
  static const char* const names[kSkinToneGroups] = {"very light", "light", "intermediate", "tan", "brown", "dark"};
  return names[std::clamp(group, 0, kSkinToneGroups - 1)];
}

SkinTones parse_skin_tones(const std::string& name) {
  if (name == "model") return SkinTones::Model;
  if (name == "balanced") return SkinTones::Balanced;
  if (name == "mixed") return SkinTones::Mixed;
  throw InvalidInput("--skin-tones", "'" + name + "' is not a way to draw skin tones",
                     "use --skin-tones model, balanced or mixed");
}

namespace {

// The mean albedo over the model's texels is linear in δ: m̄ + M δ (the clamp to [0, 1] left aside).
struct MeanAlbedo {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  Eigen::Matrix3Xd per_delta;
  explicit MeanAlbedo(const MorphableModel& model) : per_delta(Eigen::Matrix3Xd::Zero(3, model.appearance_basis.rows())) {
    const int64_t texels = int64_t(model.appearance_resolution) * model.appearance_resolution;
    int64_t n = 0;
    for (int64_t t = 0; t < texels; ++t) {
      if (!model.appearance_mask.empty() && !model.appearance_mask[size_t(t)]) continue;
      ++n;
      for (int c = 0; c < 3; ++c) {
        mean[c] += model.appearance_mean[3 * t + c];
        for (Eigen::Index k = 0; k < per_delta.cols(); ++k)
          per_delta(c, k) += double(model.appearance_basis(k, 3 * t + c)) * model.appearance_stddev[k];
      }
    }
    mean /= double(std::max<int64_t>(n, 1));
    per_delta /= double(std::max<int64_t>(n, 1));
  }
  Eigen::Vector3f operator()(const Eigen::VectorXd& delta) const { return (mean + per_delta * delta).cast<float>(); }
};

// The share of the model's texels (its appearance mask) whose albedo `a` (the model's appearance at some δ) leaves
// [0, 1] in some channel. A linear model of a few subjects extrapolates dark skin to a negative blue and green:
// clamped, a face of pure red.
double out_of_range_share(const MorphableModel& model, const std::vector<float>& a) {
  int64_t texels = 0, out = 0;
  for (size_t t = 0; 3 * t < a.size(); ++t) {
    if (!model.appearance_mask.empty() && !model.appearance_mask[t]) continue;
    ++texels;
    out += std::min({a[3 * t], a[3 * t + 1], a[3 * t + 2]}) < 0 || std::max({a[3 * t], a[3 * t + 1], a[3 * t + 2]}) > 1;
  }
  return texels ? double(out) / double(texels) : 0;
}

}  // namespace

FaceSubject model_subject(const MorphableModel& model, const RegisteredSubjects& registered, uint64_t seed, int index,
                          SkinTones tones) {
  Rng rng(seed ^ 0x6D6D5375626A6563ull, uint64_t(index));  // "mmSubjec": identities apart from the samples' streams
  FaceSubject s;
  char id[32];
  std::snprintf(id, sizeof(id), "mm/%06d", index);
  s.id = id;
  s.alpha.resize(model.shape_basis.rows());
  // N(0, 1) truncated at ±2: the tails of a model built from few subjects leave the range of skin (black albedo).
  const auto draw = [&rng] {
    for (;;) {
      const double x = rng.normal();
      if (std::abs(x) <= kSubjectTruncation) return x;
    }
  };
  for (int k = 0; k < s.alpha.size(); ++k) s.alpha[k] = draw();
  const int R = model.appearance_resolution;
  if (R <= 0) throw InvalidInput("", "the model has no appearance part", "build it from subjects with diffuse maps");
  s.delta.resize(model.appearance_basis.rows());
  for (int k = 0; k < s.delta.size(); ++k) s.delta[k] = draw();
  // δ is drawn again until its albedo is skin (out_of_range_share) and, for a balanced subject, of its group. The
  // rarest group of the demo's model takes a few dozen draws; 100,000 outside the group or 1,000 outside the range
  // of skin: the model lacks it.
  const bool balanced = tones == SkinTones::Balanced || (tones == SkinTones::Mixed && index % 2 == 1);
  const int group = (tones == SkinTones::Mixed ? index / 2 : index) % kSkinToneGroups;
  const MeanAlbedo albedo(model);
  std::vector<float> appearance;  // the model's appearance at the accepted δ
  for (int other_group = 0, out_of_range = 0;;) {
    if (balanced && skin_tone_group(typology_angle(albedo(s.delta))) != group)
      ++other_group;
    else if (appearance = model.appearance(s.delta); out_of_range_share(model, appearance) > kMaxOutOfRangeShare)
      ++out_of_range;
    else
      break;
    if (other_group == 100000 || out_of_range == 1000)
      throw InvalidInput(balanced ? (tones == SkinTones::Mixed ? "--skin-tones mixed" : "--skin-tones balanced")
                                  : "--model",
                         std::string("the model's appearance within ±2σ reaches no ") +
                             (balanced ? skin_tone_group_name(group) + std::string(" skin (ITA groups, docs/datasets.md)")
                                       : std::string("skin")) +
                             " whose albedo stays within [0, 1]",
                         balanced ? "use --skin-tones model, or build the model from subjects of that tone"
                                  : "build the model from more subjects");
    for (int k = 0; k < s.delta.size(); ++k) s.delta[k] = draw();
  }
  s.shape = model.shape(s.alpha);
  s.frame = "model";
  auto diffuse = std::make_shared<Image>(R, R, 3, ColorSpace::Linear);
  diffuse->pixels = std::move(appearance);
  for (float& v : diffuse->pixels) v = std::clamp(v, 0.f, 1.f);
  s.diffuse = diffuse;
  s.roughness = fill_map(registered.mean_roughness, kDefaultRoughness);
  s.specular = fill_map(registered.mean_specular, kDefaultSpecular);
  s.maps = "diffuse: the model's appearance at delta; roughness: " +
           (registered.mean_roughness ? std::string("mean of the registered subjects' maps")
                                      : std::to_string(kDefaultRoughness) + " (no registered roughness map)") +
           "; specular: " +
           (registered.mean_specular ? std::string("mean of the registered subjects' maps")
                                     : std::to_string(kDefaultSpecular) + " (no registered specular map)");
  return s;
}

// ---- light and pose ----

std::array<double, 27> directional_gamma(const Eigen::Vector3d& ambient, const Eigen::Vector3d& colour,
                                         const Eigen::Vector3d& direction, double strength) {
  // A clamped-cosine-like lobe: bands 1 and 2 of the direction's basis values, weighted like the Lambertian
  // convolution (band 2 a quarter of band 1), scaled so the lobe adds `strength` to the irradiance at `direction`.
  const std::array<double, 9> y = sh_basis(direction.normalized());
  const ShScales k = sh_scales();
  std::array<double, 9> lobe{};
  double peak = 0;
  for (int j = 1; j < 9; ++j) {
    const double band_weight = j < 4 ? 1.0 / (k.k1 * k.k1) : 0.25 / (k.k2 * k.k2);
    lobe[size_t(j)] = y[size_t(j)] * band_weight;
    peak += lobe[size_t(j)] * y[size_t(j)];
  }
  std::array<double, 27> g{};
  for (int c = 0; c < 3; ++c) {
    g[size_t(9 * c)] = ambient[c];
    for (int j = 1; j < 9; ++j) g[size_t(9 * c + j)] = strength * colour[c] * lobe[size_t(j)] / peak;
  }
  return g;
}

nlohmann::json Light::to_json() const {
  return {{"model", "SH order 2 (Deep3DFaceRecon) + Blinn-Phong key light"},
          {"ambient", ambient},
          {"direction", {direction.x(), direction.y(), direction.z()}},
          {"colour", {colour.x(), colour.y(), colour.z()}},
          {"strength", strength},
          {"specular", specular}};
}

SampleParams draw_params(const MorphableModel& model, const SampleRanges& r, Rng& rng) {
  SampleParams p;
  const double deg = M_PI / 180;
  p.rotation = {rng.uniform(-r.pitch_max, r.pitch_max) * deg, rng.uniform(-r.yaw_max, r.yaw_max) * deg,
                rng.uniform(-r.roll_max, r.roll_max) * deg};
  p.beta = Eigen::VectorXd::Zero(model.expression_basis.rows());
  if (rng.chance(r.expression_prob)) {
    // A few expressions at once, each bounded by expression_max.
    const int n = 1 + rng.below(3);
    for (int i = 0; i < n && p.beta.size() > 0; ++i) p.beta[rng.below(int(p.beta.size()))] = rng.uniform(-1, 1) * r.expression_max;
  }
  // The light: Deep3DFaceRecon's ambient, varied, tinted; a dominant direction in the front hemisphere.
  Light& L = p.light;
  L.ambient = kDeep3dAmbient * rng.uniform(0.75, 1.15);
  const double warmth = rng.uniform(-1, 1);  // −1 cool (blue) ... +1 warm (tungsten)
  L.colour = Eigen::Vector3d(1 + 0.12 * warmth, 1, 1 - 0.15 * warmth);
  const double az = rng.uniform(-M_PI, M_PI), el = std::acos(rng.uniform(0.2, 1.0));  // angle from the view axis
  L.direction = Eigen::Vector3d(std::sin(el) * std::sin(az), std::sin(el) * std::cos(az), std::cos(el)).normalized();
  L.strength = rng.uniform(0, r.light_max);
  L.specular = rng.uniform(0.15, 1.0) * r.specular_max;
  const Eigen::Vector3d tint(1 + rng.uniform(-0.05, 0.05), 1, 1 + rng.uniform(-0.05, 0.05));
  L.gamma = directional_gamma(L.ambient * tint.cwiseProduct(L.colour), L.colour, L.direction, L.strength);
  p.jitter = {rng.uniform(-15, 15), rng.uniform(-15, 15), rng.uniform(-120, 150)};
  return p;
}

}  // namespace bareskin::texgen
