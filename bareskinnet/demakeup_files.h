// `bareskin demakeup` on files: a photo or a folder of photos (or aligned 256² faces) through a trained BareSkinNet
// (bareskinnet.h's demakeup), each written by write_demakeup, with per-stage timings. docs/cli.md.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "bareskinnet/bareskinnet.h"
#include "core/progress.h"

namespace bareskin::bsn {

struct DemakeupFilesOptions {
  std::string input;    // a photo (PNG/JPEG/TIFF) or a folder of photos
  std::string output;   // the result folder (one subfolder per photo when the input is a folder)
  std::string run;      // the `train bareskin` run (G; names F and the model)
  std::string teacher;  // "" : the run's teacher F
  std::string model;    // "" : the run's morphable model
  std::string device = "cpu";
  int64_t uv_size = 1024;   // side of the UV map
  bool aligned = false;     // inputs are aligned 256² faces: no detection
  bool without_g = false;   // the baseline: the photo itself, without G
  bool flip_average = false;  // Demakeup::flip_average
  bool keep_going = false;  // a folder: skip photos that fail and list them
  void check() const;       // InvalidInput naming the flag
};

struct DemakeupFilesReport {
  int64_t photos = 0;
  std::vector<std::string> failed;                 // one line per skipped photo (keep_going)
  std::vector<std::map<std::string, double>> ms;   // per photo: read, detect, align, G, F, render, unwarp, write, total
};

// Runs the photos. A single photo (or aligned face) is checked — readable, RGB, a face found (or 256²) — before the
// networks load. `detector` is unused with `aligned`. InvalidInput (after the others ran, with keep_going) naming the
// input when photos failed; IoError when the input does not exist.
DemakeupFilesReport demakeup_files(const DemakeupFilesOptions& options, const detect::PhotoDetector& detector,
                                   const ProgressCallback& progress = {});

// The median milliseconds per stage over the photos (the first of several left out as the warm-up), as a table.
std::string timing_table(const std::vector<std::map<std::string, double>>& runs);

}  // namespace bareskin::bsn
