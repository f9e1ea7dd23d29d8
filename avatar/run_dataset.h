// `bareskin texgen run-dataset`: texture-inference samples made the way `bareskin run` sees a face. Each face of a
// `texgen faces` split (one lit photo with makeup, occluders and a pose) goes through G, the coefficients (F or
// mm-fit) and the unwrap exactly as in avatar_from_aligned; the sample pairs those inputs with the subject's true maps
// from a `texgen make-dataset` split. A texture net trained on these learns to undo what G, F and one photo leave in
// the unwrap, which the make-dataset samples (clean renders from three views) never show it. docs/texture.md.
#pragma once
#include <cstdint>
#include <string>

#include "avatar/avatar.h"
#include "core/progress.h"

namespace bareskin::texture {

struct RunDatasetOptions {
  std::string faces;     // a `texgen faces` split: <image>.png, json (landmarks, subject), face.png
  std::string textures;  // a `texgen make-dataset` split of the same subjects: their true maps
  std::string output;    // the dataset folder (manifest.json, texture-NNNNNN.tar), written all or nothing
  std::string model;     // the morphable model (model.safetensors)
  std::string bareskin;  // G's run ("": the face image as it is, the without-BareSkinNet pipeline)
  std::string teacher;   // F's run ("": mm-fit's fitters)
  std::string device = "cpu";
  std::string image = "makeup";  // the face image that goes through G: makeup | before
  int input_res = 256;           // UV size of the inputs (the texture run's --res)
  int64_t max_samples = 0;       // 0: every face whose subject has true maps
  int64_t shard_size = 500;      // samples per shard
  bool face_masks = true;        // each face's face.png masks its unwrap (as `run --face-mask`, `evaluate`)
  void check() const;            // InvalidInput naming the flag
};

struct RunDatasetReport {
  int64_t samples = 0;        // written
  int64_t without_truth = 0;  // faces of subjects the texture split does not hold (passed over)
  int64_t subjects = 0;       // subjects with samples
  double unwrap_psnr_db = 0;  // mean PSNR of the unwraps against the true diffuse over the texels they saw (sRGB)
};

// Loads the model and the nets and writes the dataset. InvalidInput naming the folder when no face has true maps or a
// face lacks a member; nothing is written then.
RunDatasetReport write_run_dataset(const RunDatasetOptions& options, const ProgressCallback& progress = {});

}  // namespace bareskin::texture
