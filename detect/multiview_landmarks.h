// Multi-view 3D landmarks of a textured scan: render it from N virtual cameras around the face (scan/multiview.h's
// ring), find the 68 landmarks in each render with face-api's networks, and triangulate them with Ceres
// (scan/multiview.h: robust reprojection least squares, occlusion by depth test, jaw points from silhouette views,
// snapped to the surface, per-point uncertainty). The same detection runs on real photos with known cameras
// (`landmarks scan --capture`).
#pragma once
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "detect/face_api.h"
#include "scan/multiview.h"

namespace bareskin::detect {

struct MultiviewOptions {
  int views = 16;          // virtual cameras
  int size = 384;          // render size per view
  int refinements = 2;     // landmark passes on the box the previous points imply
  double max_yaw_deg = 40, max_pitch_deg = 25;
  TriangulateOptions triangulate;
  void check() const;  // InvalidInput naming the flag
};

struct MultiviewScanLandmarks {
  MultiviewLandmarks result;
  std::vector<LandmarkView> views;  // cameras, 2D points, scores
  std::vector<Image> pictures;      // the renders (sRGB), when asked for
  double seconds_render = 0, seconds_detect = 0, seconds_triangulate = 0;
};

// One photo's 68 points and the detector's score (0 when no face scored ≥ min_score; then the points are NaN).
LandmarkView detect_view(const FaceApi& net, const Image& photo_srgb, const Camera& camera, int refinements,
                         double min_score);

// Renders, detects and triangulates. diffuse: the scan's albedo in its UV (linear), or nullptr for grey.
MultiviewScanLandmarks detect_multiview_landmarks(const FaceApi& net, const Mesh& scan, const Image* diffuse,
                                                  const MultiviewOptions& options, bool keep_pictures = false);

// `landmarks calibrate`: the detector's convention learnt on the scan folders under `scans` that hold a
// landmarks.json (68 points, mm), the first `count` of them in name order (0: all). InvalidInput when fewer than two.
LandmarkCalibration calibrate_on_scans(const FaceApi& net, const std::string& scans, int count,
                                       const MultiviewOptions& options);

// `landmarks calibrate` on files: calibrate_on_scans with face-api's networks from `weights`, written to `output`.
struct CalibrationFilesOptions {
  std::string scans, output;
  std::string weights;  // face-api's tfjs models ("" = default_face_api_folder())
  int count = 0;        // the first scans in name order (0: all)
  MultiviewOptions multiview;
  void check() const;   // InvalidInput naming the flag (multiview.check())
};
void write_calibration(const CalibrationFilesOptions& options);

// A contact sheet of the kept pictures (grid, view order): each view's detected points in red, the triangulated
// points projected back in green. InvalidInput when no pictures were kept.
Image draw_multiview(const MultiviewScanLandmarks& found);

}  // namespace bareskin::detect
