// `texgen ingest-pairs`: real before/after makeup photos (LADN's layout, or a user's own) into face shards of the same
// format `texgen faces` writes (docs/datasets.md), with "has_truth": false and no truth members (bare, coefficients,
// layer). Each photo: the detector (passed in; face-api on the Torch side) → 68 landmarks → the 5-point alignment of
// detect/align.h → 256² → masks from the landmarks and a YCbCr skin-colour test.
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/progress.h"
#include "detect/align.h"

namespace bareskin::texgen {

struct IngestOptions {
  std::string before_dir, after_dir;  // photos paired by file-name stem ("12.jpg" with "12.png")
  std::string output;                 // one shard set (prefix "faces") + manifest.json + report.json
  bool keep_going = false;            // list unmatched / faceless photos and go on, instead of failing
  int64_t shard_size = 100;
  std::string split = "test";  // the "split" field of the samples
  std::string generator = "bareskin texgen ingest-pairs";
  void check() const;  // InvalidInput naming the flag
};

struct IngestReport {
  int64_t pairs = 0, written = 0;
  std::vector<std::string> unmatched;   // photos without a partner of the same stem
  std::vector<std::string> undetected;  // photos without a face (or unreadable, with --keep-going)
  nlohmann::json to_json() const;
};

// Image files of a folder by stem (extensions .png .jpg .jpeg .tif .tiff .bmp .exr, any case), sorted.
std::vector<std::pair<std::string, std::string>> photos_by_stem(const std::string& dir);

// Everything lands in the output folder at once (AtomicDirectory) or not at all. Without keep_going the first
// unmatched, faceless or unreadable photo is an error naming it (InvalidInput; IoError when it cannot be read); with
// it they are listed (and no pair left at all is still an error).
IngestReport ingest_pairs(const IngestOptions& options, const detect::PhotoDetector& detector,
                          const ProgressCallback& progress = {});

// The masks of an aligned face from its 68 landmarks (aligned pixels) and its sRGB image: `face` = the landmark hull
// (jaw line and a forehead arc above the brows) where the colour passes the YCbCr skin test, `skin` = face less eyes,
// brows, lips and nostrils. 1 channel, Data, 0/1.
struct FaceMasks {
  Image face, skin;
};
FaceMasks landmark_masks(const detect::Landmarks68& landmarks, const Image& aligned_srgb);

// The classic YCbCr skin box (Chai & Ngan 1999) on 8-bit scaled values: 77 <= Cb <= 127 and 133 <= Cr <= 173.
bool ycbcr_skin(float r, float g, float b);

}  // namespace bareskin::texgen
