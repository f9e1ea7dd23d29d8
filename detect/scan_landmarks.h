// Automatic 3D landmarks for a textured scan: render it from the front (render/shade.h), find the 68 landmarks in
// the picture with face-api's networks (detect/face_api.h), and back-project each onto the surface through the
// rasterizer's triangle and barycentrics at that pixel. So `scan register` needs no landmarks.json.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <optional>

#include "core/image.h"
#include "core/landmarks.h"
#include "core/mesh.h"
#include "detect/face_api.h"
#include "detect/image_landmark_options.h"

namespace bareskin::detect {

struct ScanLandmarkOptions {
  int size = 512;          // render size (the face fills most of it)
  int refinements = 3;     // landmark passes, each on the box the previous points imply
  double min_score = 0.1;  // detector threshold for the first box; below it the render's coverage box is used
  void check() const;      // InvalidInput naming the flag
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

// InvalidInput("--refinements", ...) unless 0 <= refinements <= 10.
void check_refinements(int refinements);

// face-api's detector boxes span about 1.22× the landmarks' extent, starting 0.14 (x) and 0.12 (y) of it before their
// minimum (measured on astronaut.png): the box the landmark network expects around points it found before.
Box box_around(const Eigen::Matrix<double, 68, 2>& points);

// Landmarks in a photo or a render (detect/image_landmark_options.h); nothing when no face is found.
std::optional<Eigen::Matrix<double, 68, 2>> find_image_landmarks(const FaceApi& net, const Image& image,
                                                                 const ImageLandmarkOptions& options);

// find_image_landmarks over one face-api network (default_face_api_folder()) shared by the finders it returns: for
// renders (a face on black: coverage_fallback on) and for photos (off). Sets LibTorch to one intra-op thread: its
// OpenMP workers busy-wait between operators and would spin against the threads that keep the cores busy beside the
// detector in make-dataset (bench/BENCHMARKS.md, make-dataset).
using ImageLandmarkFinder = std::function<std::optional<Eigen::Matrix<double, 68, 2>>(const Image& srgb)>;
struct ImageLandmarkFinders {
  ImageLandmarkFinder render, photo;
};
ImageLandmarkFinders face_api_finders(const ImageLandmarkOptions& options);

}  // namespace bareskin::detect
