// The face-image world of `texgen faces` (docs/datasets.md): who is in a picture (subjects), and how it is posed and
// lit (per-sample parameters drawn from a seed). Geometry side, no Torch.
//
// Subjects are registered scans (their own geometry and four maps in the template UV, brought into the model's frame
// by the model's procrustes entry; their truth α, δ are least-squares projections onto the model, with the residual)
// and 3DMM samples (α, δ ~ N(0, 1); roughness and specular from the population mean of the registered maps, or
// constants without registered subjects).
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "morphable/model.h"

namespace bareskin::texgen {

// A platform-independent generator: splitmix64 seeding, xoshiro256** stream; uniform and normal draws by our own
// formulas, so the same seed gives the same samples everywhere.
class Rng {
 public:
  explicit Rng(uint64_t seed);
  Rng(uint64_t seed, uint64_t index);  // the stream of sample `index` of a run seeded `seed`
  uint64_t next();
  double uniform();                      // [0, 1)
  double uniform(double a, double b) { return a + (b - a) * uniform(); }
  double normal();                       // N(0, 1), Box-Muller
  int below(int n);                      // [0, n)
  bool chance(double p) { return uniform() < p; }

 private:
  uint64_t s_[4];
};

// Roughness and specular of 3DMM subjects (docs/datasets.md): the registered population's mean maps, or these.
constexpr float kDefaultRoughness = 0.55f, kDefaultSpecular = 0.3f;

struct FaceSubject {
  std::string id;            // "scan/subject_0003" or "mm/000017"
  bool scan = false;
  Eigen::MatrixX3d shape;    // neutral geometry in the model frame, mm (template topology)
  Eigen::VectorXd alpha, delta;          // truth (scans: least-squares projections onto the model)
  double shape_residual_mm = 0;          // scans: RMS distance between the scan and its projection
  double appearance_residual = 0;        // scans: RMS linear-RGB difference of the diffuse and its projection
  std::string frame;                     // how a scan reached the model frame
  std::shared_ptr<const Image> diffuse;  // linear RGB, template UV
  std::shared_ptr<const Image> roughness, specular;  // 1 channel, Data
  std::string maps;                      // where the maps came from
  std::vector<std::string> filled_maps;  // scans without them: "roughness", "specular" (filled, see below)
};

struct RegisteredSubjects {
  std::vector<FaceSubject> subjects;            // sorted by name
  std::shared_ptr<const Image> mean_roughness;  // population means (null without subjects)
  std::shared_ptr<const Image> mean_specular;
};

// Reads every subject folder (mesh.ply + diffuse, roughness, specular; normal maps are not used) of a `scan register`
// output, maps resampled to `map_size`². A subject without roughness or specular (a diffuse-only scan) gets the mean
// of the other subjects' maps, or kDefaultRoughness / kDefaultSpecular where none has one, listed in its filled_maps;
// one warning names them all. InvalidInput naming the folder when a subject lacks its diffuse map or its mesh is not
// in the model's topology; an empty `folder` gives no subjects.
RegisteredSubjects read_registered_subjects(const std::string& folder, const MorphableModel& model, int map_size);

// A map resampled to size² (area average for whole factors, else bilinear; a 1x1 constant is repeated).
Image resample_map(const Image& map, int size);

// Skin tone by the individual typology angle, ITA° = atan2(L* − 50, b*) of a colour in CIELAB (D65), in six groups:
// very light (> 55°), light (41–55), intermediate (28–41), tan (10–28), brown (−30–10), dark (< −30).
constexpr int kSkinToneGroups = 6;
double typology_angle(const Eigen::Vector3f& linear_rgb);
int skin_tone_group(double ita_degrees);  // 0 (very light) … 5 (dark)
const char* skin_tone_group_name(int group);

// How 3DMM subjects' skin tones are drawn: as the model's population (δ ~ N(0, 1)); the six ITA groups in turn
// (subject `index` gets group index mod 6; δ is drawn until its mean albedo falls there), so that a world holds as
// many dark as light skins whatever the scans the model was built from; or mixed: the even subjects as the model's
// population (the same draws as `model`), the odd ones balanced (subject 2k + 1 gets group k mod 6).
enum class SkinTones { Model, Balanced, Mixed };
SkinTones parse_skin_tones(const std::string& name);  // model | balanced | mixed; InvalidInput naming --skin-tones

// The 3DMM subject number `index` of a run seeded `seed`: α, δ ~ N(0, 1) truncated at ±kSubjectTruncation, δ drawn
// again until its albedo stays within [0, 1] on all but kMaxOutOfRangeShare of the model's texels (beyond, the clamp
// paints a face of one colour: no skin) and its skin tone is the one `tones` asks for (InvalidInput when the model's
// appearance within the truncation reaches no such skin).
constexpr double kSubjectTruncation = 2.0;
constexpr double kMaxOutOfRangeShare = 0.02;
FaceSubject model_subject(const MorphableModel& model, const RegisteredSubjects& registered, uint64_t seed, int index,
                          SkinTones tones = SkinTones::Model);

// The SH light and the specular key light of one sample.
struct Light {
  std::array<double, 27> gamma{};          // absolute (Deep3DFaceRecon's 0.8 ambient included), channel-major
  Eigen::Vector3d direction = {0, 0, 1};   // the dominant light, unit, towards the light, camera frame
  Eigen::Vector3d colour = {1, 1, 1};      // its colour (linear)
  double ambient = 0.8, strength = 0;      // SH: ambient per channel before tint, directional lobe
  double specular = 0;                     // the key light's specular intensity
  nlohmann::json to_json() const;
};

struct SampleRanges {
  double yaw_max = 30, pitch_max = 15, roll_max = 10;  // degrees
  double expression_max = 0.5;   // |β| bound in standard deviations
  double expression_prob = 0.3;  // the rest are neutral
  double light_max = 0.6;        // strength of the directional lobe over the ambient
  double specular_max = 0.6;
};

// Pose, expression and light of a sample (yaw/pitch/roll uniform in their ranges, β mostly neutral).
struct SampleParams {
  Eigen::Vector3d rotation;  // [rx (pitch), ry (yaw), rz (roll)] radians
  Eigen::VectorXd beta;
  Light light;
  Eigen::Vector3d jitter;    // the "photo" before alignment: mm offset of the head (x, y, z)
};
SampleParams draw_params(const MorphableModel& model, const SampleRanges& ranges, Rng& rng);

// The SH coefficients (absolute) of an ambient per channel plus a directional lobe of `strength` towards `direction`
// (irradiance = ambient·k0 + strength at the direction itself).
std::array<double, 27> directional_gamma(const Eigen::Vector3d& ambient, const Eigen::Vector3d& colour,
                                         const Eigen::Vector3d& direction, double strength);

}  // namespace bareskin::texgen
