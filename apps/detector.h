// What the geometry commands take from the Torch side when it is built (BARESKIN_WITH_DETECT): face-api's detectors
// (detect/landmark_files.h) with LibTorch's threads set from --threads. Defined in apps/landmarks_command.cc, or in
// apps/scan_command.cc as "none" without the Torch side.
#pragma once
#include "apps/cli.h"
#include "detect/align.h"
#include "detect/image_landmark_options.h"
#include "scan/register_folder.h"

namespace bareskin::cli {

// face-api's networks on a front render of the scan (detect/scan_landmarks.h), or with `calibration` (a `landmarks
// calibrate` file) on 16 views, triangulated and calibrated (detect/multiview_landmarks.h); sets LibTorch's threads.
// Empty without the Torch side: such scans then take the fallback alignment.
ScanLandmarkDetector scan_landmark_detector(const Globals& globals, const std::string& calibration = "");

// face-api's networks on a photo (texgen faces, ingest): the faces with their 68 landmarks, best first; the detector
// looks at `input_size`² (a multiple of 32). Empty without the Torch side.
detect::PhotoDetector photo_detector(const Globals& globals, int input_size = detect::kDetectorInputSize);

// LibTorch's intra-op threads follow --threads (0: every core). A no-op without the Torch side.
void set_torch_threads(const Globals& globals);

}  // namespace bareskin::cli
