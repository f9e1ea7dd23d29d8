// Cameras of a real multi-camera capture from COLMAP (docs/pipeline.md, "Captures"): the `colmap` command line
// (Debian's package; feature extraction, exhaustive matching and mapping on the CPU) or a user's existing sparse model,
// read from its TXT export; the model's frame brought onto the scan's by a similarity (a landmark-based start, then
// ICP of the model's 3D points against the mesh with scale). Geometry only: no COLMAP headers, no Torch.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/similarity.h"
#include "render/camera.h"
#include "scan/multiview.h"

namespace bareskin {

struct ColmapImage {
  std::string name;  // file name relative to the image folder
  Camera camera;     // in the model's frame, render/camera.h's convention (looks down −z)
};

struct ColmapModel {
  std::vector<ColmapImage> images;  // registered images only
  Eigen::MatrixX3d points;          // the sparse 3D points
  double reprojection_px = 0;       // mean of the points' reprojection errors (points3D.txt's ERROR)
  long median_features = -1;        // when COLMAP was run here: SIFT features per photo (median)
  long verified_pairs = -1;         // and photo pairs with 15+ verified matches
};

// How COLMAP is run (defaults: COLMAP's own, CPU). Exhaustive matching: every pair, fine up to a few hundred photos.
struct ColmapOptions {
  int threads = 0;                     // 0: every core
  int max_features = 8192;             // SIFT features per photo
  int max_image_size = 3200;           // photos are downscaled to this longest side for SIFT
  double peak_threshold = 0.02 / 3;    // SIFT's contrast threshold (lower: more features on faint texture)
  bool domain_size_pooling = false;    // DSP-SIFT descriptors (better matches across scale, slower)
  int init_min_inliers = 100;          // inliers the mapper's first image pair needs
  double focal_px = 0;                 // the rig's calibrated focal length in px, held fixed in bundle adjustment
                                       // (0: COLMAP's, from EXIF, else a guess of 1.2 x the photo's size refined by
                                       // bundle adjustment: far off for long lenses, and it drifts run to run)
  void check() const;                  // InvalidInput naming the flag
};

// Reads cameras.txt, images.txt and points3D.txt of a TXT model. Pinhole models (SIMPLE_PINHOLE, PINHOLE) are read
// as they are; radial ones (SIMPLE_RADIAL, RADIAL, OPENCV) keep their focal and principal point and drop the
// distortion (fine for the small distortion of rig cameras; say so in the log). InvalidInput naming the file for
// malformed lines or an unknown camera model.
ColmapModel read_colmap_text_model(const std::string& dir);
// The same from the three files' text; `dir` names the folder in errors.
ColmapModel parse_colmap_text_model(const std::string& cameras_txt, const std::string& images_txt,
                                    const std::string& points_txt, const std::string& dir);

// Runs colmap on the photos in `images` (CPU SIFT, one shared SIMPLE_PINHOLE camera, exhaustive matching, mapper) in
// `work` and reads the largest model. `log` gets COLMAP's output. IoError when colmap is missing; InvalidInput naming
// the folder when it reconstructs nothing.
ColmapModel run_colmap(const std::string& images, const std::string& work, const ColmapOptions& options,
                       const std::string& log);

// What COLMAP's database in `work` holds: the median SIFT features per photo and the photo pairs with 15 or more
// verified (two-view geometry) matches, read with the sqlite3 command; -1 each when it cannot be read.
std::pair<long, long> colmap_database_stats(const std::string& work);

// The similarities below take the model's frame to the scan's: x_scan = s R x_model + t.
// The similarity taking `from` onto `to` over the rows finite in both (Umeyama); InvalidInput with fewer than 4.
Similarity similarity_from_points(const Eigen::MatrixX3d& from, const Eigen::MatrixX3d& to);

// ICP with scale of the model's points onto the mesh from `start`: closest points, the worst `trim` fraction left
// out each round, `iterations` rounds. rms_mm: the kept points' RMS distance at the end.
Similarity align_points_to_mesh(const Eigen::MatrixX3d& points, const Mesh& mesh, Similarity start, int iterations,
                                double trim, double* rms_mm = nullptr);

// The rows of `points` within `max_mm` of the mesh once moved by `model_to_scan`: the model's points on the head,
// without those on a backdrop, floor or rig.
Eigen::MatrixX3d points_near_mesh(const Eigen::MatrixX3d& points, const Mesh& mesh, const Similarity& model_to_scan,
                                  double max_mm);

// A camera of the model's frame in the scan's frame (same pixels for corresponding points).
Camera transform_camera(const Camera& camera, const Similarity& model_to_scan);

}  // namespace bareskin
