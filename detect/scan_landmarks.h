// Automatic 3D landmarks for a textured scan: render it from the front (render/shade.h), find the 68 landmarks in
// the picture with face-api's networks (detect/face_api.h), and back-project each onto the surface through the
// rasterizer's triangle and barycentrics at that pixel. So `scan register` needs no landmarks.json.
#pragma once
#include <Eigen/Core>

#include "core/image.h"
#include "core/landmarks.h"
#include "core/mesh.h"
#include "detect/face_api.h"

namespace bareskin::detect {

struct ScanLandmarkOptions {
  int size = 512;          // render size (the face fills most of it)
  int refinements = 3;     // landmark passes, each on the box the previous points imply
  double min_score = 0.1;  // detector threshold for the first box; below it the render's coverage box is used
};

struct ScanLandmarks {
  Landmarks landmarks;              // 68 × 3, mm, on the scan's surface
  double detector_score = 0;        // 0 when the detector found nothing and the coverage box was used
  Eigen::Matrix<double, 68, 2> px;  // the 2D landmarks in the render
  Image picture;                    // the render (sRGB) the landmarks were found in
  int off_surface = 0;              // points that fell off the silhouette and were snapped to the nearest covered pixel
};

// diffuse: the scan's albedo in its UV (linear), or nullptr for grey. InvalidInput if the scan does not cover the
// render (empty mesh, NaN) or a landmark lies more than size/16 px from the
// surface.
ScanLandmarks detect_scan_landmarks(const FaceApi& net, const Mesh& scan, const Image* diffuse,
                                    const ScanLandmarkOptions& options = {});

}  // namespace bareskin::detect
