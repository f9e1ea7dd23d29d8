// The files of `bareskin landmarks detect` and `landmarks scan`: a photo's faces and their iBUG-68 landmarks
// (face-api's networks, face_api.h) as the landmark file every other command reads, and a textured scan's 3D landmarks
// (scan_landmarks.h, multiview_landmarks.h, capture_landmarks.h), each with an optional drawing.
#pragma once
#include <torch/torch.h>

#include <string>

#include "detect/align.h"
#include "detect/capture_landmarks.h"
#include "detect/face_api.h"
#include "detect/multiview_landmarks.h"
#include "detect/scan_landmarks.h"
#include "scan/register_folder.h"

namespace bareskin::detect {

struct PhotoLandmarksOptions {
  std::string photo;    // the photo (any format core/image_io.h reads)
  std::string output;   // the landmark JSON (*.json)
  std::string draw;     // "" or the photo with boxes and landmarks drawn (PNG/JPEG)
  std::string weights;  // face-api's tfjs models ("" = default_face_api_folder())
  torch::Device device = torch::kCPU;
  std::string device_name = "cpu";  // as given, recorded in the file
  DetectOptions detect;
  void check() const;  // InvalidInput naming the file or flag
};

// Writes `output` (and `draw`): {"scheme": "ibug68", "units": "px", "image", "width", "height", "points" (the best
// face's), "score", "faces": [{"score", "box": [x, y, w, h], "points"}], "detector"}. InvalidInput when an output
// would overwrite the photo, the output is not *.json, or no face scores above the minimum.
void detect_photo_landmarks(const PhotoLandmarksOptions& options);

struct ScanLandmarkFilesOptions {
  std::string scan, texture;  // a scan folder or a mesh file, and then its diffuse map ("" = grey)
  std::string output;         // the 3D landmark JSON (mm), as scan/landmarks.json
  std::string draw;           // "" or the front render (or the views) with the 2D landmarks drawn (PNG)
  std::string weights;        // face-api's tfjs models ("" = default_face_api_folder())
  ScanLandmarkOptions detect;
  MultiviewOptions multiview;  // views 1: the front render, back-projected; more: triangulated
  bool no_jaw = false;         // with views > 1: the jaw contour left out (null points)
  std::string calibration;     // "" or a `landmarks calibrate` file applied to the triangulated points
  std::string uncalibrated;    // "" or where the points before the calibration go
  std::string save_views;      // "" or a folder for the views and their cameras (a synthetic capture)
  std::string capture, sparse;  // "" or the rig's photos (and an existing COLMAP TXT model of them)
  ColmapOptions colmap;
  void check() const;  // InvalidInput for options that do not go together
};

// Writes `output` (and `uncalibrated`, `draw`, `save_views`). InvalidInput for options that do not go together.
void scan_landmark_files(ScanLandmarkFilesOptions options);

// face-api's networks as the detectors the geometry commands take. A scan's landmarks (`scan register`, `mm-build` for
// scans without landmarks.json): the front render (scan_landmarks.h), or with `calibration` (a `landmarks calibrate`
// file) 16 views triangulated and calibrated (multiview_landmarks.h). A photo's faces (`texgen faces`, ingest) with
// their 68 landmarks, best first, the detector looking at input_size² (a multiple of 32). The scan detector loads the
// networks at its first scan, the photo detector when it is made.
ScanLandmarkDetector face_api_scan_detector(const std::string& calibration = "");
PhotoDetector face_api_photo_detector(int input_size = kDetectorInputSize);

}  // namespace bareskin::detect
