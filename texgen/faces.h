// `texgen faces`: the face-image world as training and evaluation data (docs/datasets.md). Each sample is a face
// (a registered scan or a 3DMM sample) with makeup, posed, lit by SH light plus a specular key light, in front of a
// background, maybe behind occluders, aligned the way real photos are (detect → 68 landmarks → Deep3DFaceRecon's
// 5-point alignment, detect/align.h) and then rendered directly by the canonical camera, so the stored coefficients
// reproduce the aligned picture exactly. One rasterization gives every member: makeup.png, before.png, bare.png,
// skin.png, face.png, the makeup layer, and json (landmarks, coefficients, camera, alignment, light).
//
// Splits are by subject (no identity in two splits); shards go to <output>/{train,val,test}/ with a manifest each.
// The same seed gives the same bytes; a killed run resumes (finished shards are kept); --shard i --shards n spreads
// the shards over machines.
#pragma once
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/progress.h"
#include "detect/align.h"
#include "texgen/face_world.h"
#include "core/shards.h"

namespace bareskin::texgen {

struct FacesOptions {
  std::string registered;         // `scan register` output (may be empty: 3DMM subjects only)
  std::string model;              // model.safetensors (mm-build)
  std::string output = "faces";
  int64_t count = 1000;           // samples over all splits
  uint64_t seed = 1;
  int mm_subjects = 90;           // 3DMM identities beside the registered ones
  std::string skin_tones = "model";  // their skin tones: model | balanced | mixed (face_world.h, SkinTones)
  double val = 0.1, test = 0.1;   // subjects per split: a count (>= 1) or a fraction (< 1)
  int64_t shard_size = 100;       // samples per shard
  int shard = 0, shards = 1;      // this worker of `shards`
  std::string align = "detector";  // detector | truth
  SampleRanges ranges;
  double occluder_prob = 0.3;
  std::string styles = "all", exclude_styles;
  int map_size = 512;             // registered maps are resampled to this (the face is ~180 px wide at 256²); the
                                  // makeup is painted at this size
  int layer_size = 256;           // the stored makeup layer (layer.png, finish.png)
  std::string backgrounds = kSkimageDataFolderDefault;  // photo folder ("" or missing: procedural only)
  std::string generator = "bareskin texgen faces";      // name and version, for the manifest

  static constexpr const char* kSkimageDataFolderDefault = "/usr/lib/python3/dist-packages/skimage/data";
  void check() const;  // InvalidInput naming the flag
  nlohmann::json to_json() const;
};

// The split a subject falls in, and which samples and shards each split holds.
struct FacesPlan {
  std::vector<std::string> subjects;      // registered (sorted) then mm/000000...
  std::vector<int> subject_split;         // 0 train, 1 val, 2 test
  std::vector<int> sample_subject;        // per sample index
  std::vector<std::vector<int64_t>> split_samples;  // per split, ascending indices
  int64_t shards_in(int split, int64_t shard_size) const;
};
extern const char* const kSplitNames[3];
FacesPlan plan_faces(const FacesOptions& options, const std::vector<std::string>& registered_ids);

struct FacesReport {
  int64_t samples_written = 0, shards_written = 0, shards_skipped = 0;
  std::vector<std::string> complete_splits;  // manifests written
  double seconds = 0;
  int64_t detected = 0, detector_runs = 0;   // --align detector: faces found on the pre-alignment render
  double detector_seconds = 0;
  nlohmann::json stage_seconds;              // CPU seconds per stage, all threads
  nlohmann::json to_json() const;
};

// The generator: the world (model, subjects, backgrounds) loaded once; samples rendered from (seed, index).
class FaceGenerator {
 public:
  // Reads the model and the registered subjects. InvalidInput/IoError naming the file for bad input.
  explicit FaceGenerator(FacesOptions options);
  ~FaceGenerator();

  const FacesPlan& plan() const;
  // Renders sample `index` (its split's style pool, its subject). `detector` is used for --align detector.
  shards::Sample render(int64_t index, const detect::PhotoDetector& detector) const;
  // Every shard of this worker not yet on disk, then the manifests of the splits that are complete.
  FacesReport run(const detect::PhotoDetector& detector, const ProgressCallback& progress);

 private:
  struct World;
  std::unique_ptr<World> world_;
};

// `texgen faces` on files: the generator built (every input read and checked before anything is written), this
// worker's shards written into options.output, and its report (report.json, or report-<shard>.json with several
// workers) beside them. Tunes glibc's allocator for the generator's many image-sized blocks.
FacesReport write_faces(const FacesOptions& options, const detect::PhotoDetector& detector,
                        const ProgressCallback& progress = {});

}  // namespace bareskin::texgen
