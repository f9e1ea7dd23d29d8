// `bareskin run`: a face photo → a relightable avatar (BareSkinNet §5, Fig. 1): detect → align (5 points, 256²) →
// G (bare skin; skipped with --no-bareskin) → F (3DMM coefficients; mm-fit's fitters when no F is given) → mesh → unwrap into the template UV → pix2pixHD (the
// four maps) → SRGAN ×4 → an avatar folder (OBJ + GLB, maps at both sizes, bare-skin image, coefficients, relit
// previews). Also `bareskin evaluate`, the paper's Table 1 protocol. Geometry side (model, unwrap, fit, rendering)
// plus the texture nets; not built on the Torch-only GPU machine. docs/texture.md.
#pragma once
#include <functional>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "detect/align.h"
#include "morphable/coefficients.h"
#include "morphable/fit.h"
#include "morphable/model.h"
#include "texture/pix2pixhd.h"
#include "upscale/srgan.h"
#include "recon/recon_photo.h"
#include "texgen/texture_sample.h"

namespace bareskin::data {
struct Batch;
}

namespace bareskin::texture {

// A face detector: the 68 landmarks (photo pixels) of each face of an sRGB photo, best first (the command passes
// face-api's networks in).
using FaceFinder = std::function<std::vector<detect::Landmarks68>(const Image& srgb)>;

// G: an aligned sRGB face (256², values in [0, 1]) → its bare-skin image (same size, sRGB).
using Demakeup = std::function<Image(const Image& aligned)>;

// G of a BareSkinNet run (`bareskin train bareskin`: the run folder — its stage2/, else stage1/ — or a checkpoint),
// on `device`; only G's weights are read (bareskinnet/bareskinnet.h's load_generator). InvalidInput naming the file when
// it is not a BareSkinNet checkpoint.
Demakeup load_demakeup(const std::string& run, const std::string& device);

struct AvatarOptions {
  int input_res = 0;        // UV size of the unwrap and 3DMM maps (0: the texture run's training size)
  int preview_size = 512;   // relit previews
  bool upscale = true;      // 4K maps (SRGAN where a run is given for the map and it is in sr_maps, else bicubic)
  // The maps SRGAN upscales (when a run is given for them); the others are upscaled bicubically. The default is the
  // maps where SRGAN beat bicubic on held-out maps; on the smooth normal map it gained nothing for a net's time
  // (bench/BENCHMARKS.md, texture inference).
  std::set<std::string> sr_maps = {"diffuse", "roughness", "specular"};
  LandmarkFitOptions landmark_fit;
  PhotometricFitOptions photometric;
  void check() const;  // InvalidInput naming the flag (and the fits' check())
};

// Everything one photo gives.
struct Avatar {
  Image aligned, bare;                  // 256² sRGB (bare = aligned without G)
  detect::Landmarks68 landmarks;        // in the aligned frame
  Coefficients coefficients;            // canonical camera at 256²
  Image fit;                            // the fitted 3DMM (appearance, fitted light) over the aligned image
  Mesh mesh;                            // S(α, β) in the model frame, template UVs
  Image unwrap, confidence;             // the network's first inputs (sRGB colour, grey)
  std::map<std::string, Image> maps;    // the four maps at the net's size (diffuse sRGB, the others data)
  std::map<std::string, Image> maps_hr; // ×4
  std::vector<Image> previews;          // relit under three lights (sRGB)
  std::map<std::string, double> seconds;      // per stage, wall clock
  std::map<std::string, double> cpu_seconds;  // per stage, the process's CPU time (all threads)
  std::string upscaled_with;            // per map: "srgan" | "bicubic"
  std::string coefficients_from;        // "F" (the reconstruction net) | "mm-fit" (landmark + photometric fits)
};

// The nets of a run command, checked against each other and the model: InvalidInput naming the files when the
// texture run was trained for another model file (its recorded CRC-32), an upscaler is for an unknown map, two
// upscalers claim the same map, an upscaler came from another model's dataset, or F is not a recon run of this
// model's sizes.
struct AvatarNets {
  TextureNet texture;
  std::map<std::string, Upscaler> upscalers;  // by map
  std::shared_ptr<const recon::TrainedRecon> F;  // the coefficients' net; null: mm-fit
};
AvatarNets load_avatar_nets(const std::string& model_path, const std::string& texture_run,
                            const std::vector<std::string>& upscale_runs, const std::string& device,
                            const std::string& teacher_run = "");

// The coefficients of avatar_from_aligned: `F` (the reconstruction net) on the bare image when given, else mm-fit's
// landmark fit (pose, α, β) on the landmarks and its photometric fit (δ, γ) on the bare image. Canonical camera at
// 256²; extra["coefficients_from"] says which ("F" | "mm-fit").
Coefficients fit_coefficients(const Image& bare, const detect::Landmarks68& landmarks, const MorphableModel& model,
                              const recon::TrainedRecon* F, const AvatarOptions& options);

// The texture net's inputs for one aligned face, as `texgen make-dataset` names them: the face unwrapped into the
// template UV at res² through its fit (sRGB colour, grey confidence; `face_mask` as in avatar_from_aligned) and the
// fitted 3DMM's maps. InvalidInput for a mask of another size.
struct TextureInputs {
  Image unwrap, confidence;
  texgen::ModelUvMaps mm;
  std::map<std::string, torch::Tensor> tensors() const;  // by input name ([1, C, H, W] in [0, 1])
};
TextureInputs texture_inputs(const Image& bare, const Coefficients& c, const MorphableModel& model, int res,
                             const Image& face_mask = {});

// The whole pipeline on an already aligned 256² face with its 68 landmarks (aligned pixels); `G` may be empty
// (--no-bareskin). The coefficients come from nets.F on G's image (the aligned face without G) when it is given,
// else from mm-fit's landmark fit on the landmarks and photometric fit on G's image. `face_mask` (optional, 256²,
// first channel): the face's own pixels, 1 where the face is seen and nothing covers it (a face segmentation: no hair,
// glasses, hands or background); the unwrap counts a texel whose sample touches a pixel below 1 as unseen, so the
// texture net fills it as it fills the masks it was trained with instead of copying the occluder into the maps.
// InvalidInput for a mask of another size. Deterministic.
Avatar avatar_from_aligned(const Image& aligned, const detect::Landmarks68& landmarks, const MorphableModel& model,
                           const AvatarNets& nets, const Demakeup& G, const AvatarOptions& options,
                           const Image& face_mask = {});

// The pipeline on a photo: the best face of `detector`, aligned; InvalidInput naming `source` when there is none.
// `face_mask` (optional): the photo's face segmentation at the photo's size, aligned with the photo.
Avatar avatar_from_photo(const Image& photo, const std::string& source, const FaceFinder& detector,
                         const MorphableModel& model, const AvatarNets& nets, const Demakeup& G,
                         const AvatarOptions& options, const Image& face_mask = {});

// `run --face-mask`: the segmentation of `photo` read from `path` (grey, or its first channel), values in [0, 1].
// InvalidInput naming the file when it cannot be read or is not the photo's size.
Image read_face_mask(const std::string& path, const Image& photo);

// Writes the avatar folder atomically (AtomicDirectory: all or nothing). Each map is encoded once (core/png_encoding.h),
// on `threads` threads; the GLB embeds the map files' own PNG bytes.
void write_avatar(const std::string& dir, const Avatar& avatar, const nlohmann::json& report, int threads = 2);

// The map types of a comma-separated list ("diffuse,normal"); InvalidInput naming `option` for an unknown one.
std::set<std::string> parse_map_list(const std::string& list, const std::string& option);

// `bareskin run` on files: the photo read and checked, the model and the nets loaded (timed per part), the photo's
// face found by face-api's networks from `weights` (or taken from the landmark file `landmarks`), the pipeline run and
// the avatar folder written with its report (the inputs, sr_maps as given, the device, the load and pipeline times).
struct RunFilesOptions {
  std::string photo, output, model, texture;
  std::vector<std::string> upscale;  // SRGAN runs, one per map
  std::string bareskin;              // "" : without G
  std::string teacher;               // "" : mm-fit's fitters instead of F
  std::string device = "cpu";
  std::string weights;               // face-api's tfjs models ("" = default_face_api_folder())
  std::string landmarks;             // "" or the photo's 68 landmarks (a landmark file, px): no detector
  std::string face_mask;             // "" or the photo's face segmentation (read_face_mask)
  std::string sr_maps;               // the --sr-maps list as given, recorded in the report (avatar.sr_maps holds it)
  AvatarOptions avatar;
  int threads = 2;                   // map encoding threads
  void check() const;                // InvalidInput naming the flag (avatar.check())
};
struct RunFilesResult {
  double seconds = 0;                // the pipeline's wall time (loading not included)
  std::string upscaled_with;
};
RunFilesResult run_files(const RunFilesOptions& options);

// Torch tensors ↔ images ([1, C, H, W] or [C, H, W] in [0, 1]).
Image tensor_image(const torch::Tensor& t, ColorSpace space);
torch::Tensor image_tensor(const Image& image);

// Face samples name scans "scan/subject_0003", texture samples "subject_0003": the one key for both.
std::string subject_key(const std::string& name);
// The 68 landmarks (aligned px) of the first face of a `texgen faces` batch (its "landmarks" member).
detect::Landmarks68 sample_landmarks(const data::Batch& batch);

// InvalidInput naming `faces` (a texgen faces split) when its first sample has no face.png (faces made before the
// segmentation existed), with what to do: `option` (e.g. "--no-face-masks") unwraps the whole face instead.
void require_face_masks(const std::string& faces, const std::string& option);

// ---- bareskin evaluate: the paper's Table 1 protocol ----
struct EvaluateOptions {
  std::string faces;      // held-out faces split (texgen faces: makeup.png, before.png, json)
  std::string textures;   // the texture split of the same subjects (true maps by json "subject"); optional
  std::string output;     // report folder: table.md, table.csv, per_sample.csv, charts
  int64_t max_samples = 0;  // 0: all
  bool face_masks = true;   // each sample's face.png (the face less its occluders) masks its unwraps
  AvatarOptions avatar;
  void check() const;  // InvalidInput naming the flag
};
// Runs the pipeline on every sample's makeup image with and without G and on its before image without and with G;
// RMSE (0–255), PSNR, SSIM per map against three references: (a) the before image's maps without G for both rows
// (the paper's wording), (a') the before image's maps through the row's own pipeline (with G for the with-G row:
// stability under makeup), (b) the true maps; SRGAN vs bicubic vs the true 4K diffuse where the texture split has
// it. With face_masks, the sample's face.png is every unwrap's face mask (the segmentation `run --face-mask` takes).
// Returns the summary table as JSON.
nlohmann::json evaluate_table1(const EvaluateOptions& options, const MorphableModel& model, const AvatarNets& nets,
                               const Demakeup& G);

}  // namespace bareskin::texture
