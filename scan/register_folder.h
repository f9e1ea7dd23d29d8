// `scan register` over a folder of scans (also what mm-build runs first): each scan folder's mesh registered to the
// template (scan/register.h), whichever maps the scan has transferred into the template UV (scan/transfer.h), an
// error report per scan (against the truth when the scan came from `scan synth`) and QA heat maps; a summary over the
// folder. Resumable: scans that already have a report are skipped.
#pragma once
#include <functional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/landmarks.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "scan/register.h"
#include "scan/uv_maps.h"
#include "template/template_face.h"

namespace bareskin {

// Landmarks found on a scan that has no landmarks.json (the face detector lives on the Torch side; the command passes
// it in): 68 x 3 points in mm on the scan, the detector's score, points snapped onto the silhouette.
struct DetectedLandmarks {
  Landmarks landmarks;
  double detector_score = 0;
  int snapped_to_silhouette = 0;
  int views = 1;            // cameras the points were triangulated from (1: the front render)
  bool calibrated = false;  // mapped onto the template's convention (then all 68 are used)
  std::vector<double> sigma_mm;  // per-point uncertainty when known
};
using ScanLandmarkDetector = std::function<DetectedLandmarks(const Mesh& scan, const Image* diffuse_linear)>;

struct RegisterFolderOptions {
  std::string scans = "scans", output = "registered";
  bool keep_going = false;    // go on after a scan fails; InvalidInput listing the failures at the end
  bool no_landmarks = false;  // ignore landmark files: the fallback alignment
  double scale = 1;           // multiplies every scan and its landmarks.json on reading (1000: scans in metres)
  double heat_max_mm = 2.0;   // error shown red in the QA heat maps
  BakeOptions maps = [] {     // resolution 0: no texture transfer
    BakeOptions o;
    o.resolution = 1024;
    return o;
  }();
  RegisterOptions nicp;
  // The reference diffuse in the template UV for nicp.texture (docs/pipeline.md: the mean of a first pass's
  // transferred diffuse maps); required when nicp.texture.iterations > 0.
  std::string texture_reference;
  // The 3DMM (mm-build's model.safetensors, built on this template) whose shape is fitted before NICP (empty: none).
  std::string model;
  // For scans without landmarks.json (unless no_landmarks); empty: the fallback alignment.
  ScanLandmarkDetector detect;
  void check() const;  // InvalidInput naming the flag (and nicp.check(), maps.check() when maps are transferred)
};

// Per-point uncertainty (mm) from the text of a landmark file `landmarks scan --views` wrote (its 68 "detail" entries'
// sigma_mm; 0 where one has none: unknown); empty for a plain landmark file. scan register reads it beside the points,
// so a saved detection weighs its points as a detection in the same run does (the model fit, --sigma-weighted-landmarks).
std::vector<double> parse_landmark_sigma(const std::string& text);

// Registers every scan folder of options.scans that has no report in options.output yet (in parallel; keep_going
// collects failures), writes options.output/summary.json and returns options.output/<id> for every scan. Throws
// InvalidInput when a scan failed (after the others, with keep_going).
std::vector<std::string> register_folder(const TemplateFace& face, const RegisterFolderOptions& options,
                                         const ProgressCallback& progress = {});
// The same with the template read from `template_dir` ("": the default search) once the options are checked.
std::vector<std::string> register_folder(const std::string& template_dir, const RegisterFolderOptions& options,
                                         const ProgressCallback& progress = {});

}  // namespace bareskin
