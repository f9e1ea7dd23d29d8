// `landmarks scan --capture`: the landmarks of a scan triangulated on the rig's own photos. COLMAP (scan/colmap.h)
// recovers the photos' cameras, or a user's sparse model gives them; the model's frame is brought onto the scan by a
// similarity from landmarks 17-67 (triangulated in both frames), then ICP of the model's head points against the mesh;
// the landmarks are then detected in each photo and triangulated with those cameras (scan/multiview.h). A photo whose
// camera disagrees with the others (scan/multiview.h's inconsistent_views) is left out, with a warning naming it. A
// model whose aligned landmarks land more than 5% of the scan's size from the virtual views' is distorted (COLMAP's
// matching is not repeatable, and now and then a run gives such a model): COLMAP runs once more, then the fallback.
#pragma once
#include <nlohmann/json.hpp>
#include <string>

#include "core/mesh.h"
#include "detect/face_api.h"
#include "detect/multiview_landmarks.h"
#include "scan/colmap.h"

namespace bareskin::detect {

struct CaptureLandmarkOptions {
  std::string photos;  // the capture folder
  std::string sparse;  // an existing COLMAP TXT model of the photos ("": run COLMAP)
  ColmapOptions colmap;
  void check() const;  // InvalidInput naming the flag
};

// `found` holds the scan's virtual-view landmarks (detect_multiview_landmarks), the start of the alignment. On success
// found.result and found.views are replaced by the photos' and a summary (photos, registered cameras, points,
// reprojection, alignment, each camera on the scan) is returned. When COLMAP cannot reconstruct the folder, too few
// landmarks are found on the photos or the model stays distorted, one warning names the fallback (the virtual views,
// left in `found`) and null is returned. InvalidInput when the folder does not exist or the sparse model cannot be
// read.
nlohmann::json capture_landmarks(const FaceApi& net, const Mesh& scan, MultiviewScanLandmarks& found,
                                 const CaptureLandmarkOptions& capture, const MultiviewOptions& options);

}  // namespace bareskin::detect
