// A synthetic multi-camera capture of a textured scan (docs/pipeline.md, "Captures"): photos from rows of cameras
// around the face, as a photogrammetry rig takes them, to test `landmarks scan --capture` (COLMAP's cameras) against
// the scan's truth. What makes such photos usable by structure from motion is what real rigs have: detail on the
// skin at the photo's pixel size (the scan's diffuse near its native resolution, supersampled like a lens and sensor
// would), and a textured backdrop (a speckle pattern on a sphere around the rig) that stays still while the cameras
// look from all sides. Geometry only.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "render/camera.h"

namespace bareskin {

struct CaptureOptions {
  int photos = 24;             // cameras, in rows (3 rows from 12 photos on)
  int size = 1536;             // photo width and height, px
  double distance = 1000;      // camera to the face's centre, mm
  double field_mm = 320;       // width seen at the face's centre (focal = size * distance / field_mm)
  double max_yaw_deg = 70;     // the rows span yaw in [-max, max]
  double max_pitch_deg = 20;   // and pitch in [-max, max]
  int supersample = 2;         // rendered at size * supersample, then box-filtered (the lens/sensor's low-pass)
  bool backdrop = true;        // a speckle backdrop behind the head; false: black
  double noise = 0.004;        // sensor noise, sigma in linear units
  uint64_t seed = 1;           // backdrop pattern and noise
  void check() const;          // InvalidInput naming the flag
};

// The capture's cameras looking at `target` (render/camera.h's pinhole convention).
std::vector<Camera> capture_cameras(const CaptureOptions& options, const Eigen::Vector3d& target);

// The backdrop's albedo (linear grey) at world point `x` on the sphere: dots of three sizes on a mid-grey.
float backdrop_albedo(const Eigen::Vector3d& x, uint64_t seed);

// One photo (sRGB): the scan shaded with render/shade.h's default light (diffuse: linear albedo in the scan's UV, or
// nullptr for grey), the backdrop where the scan does not cover. `index` seeds the photo's noise.
Image render_capture_photo(const Mesh& scan, const Image* diffuse, const Camera& camera, const Eigen::Vector3d& target,
                           const CaptureOptions& options, int index);

// Writes a capture folder: the pictures as <stem>_NN.png (sRGB) and their cameras in cameras.json (the format
// `landmarks scan --capture` and docs/file_formats.md describe).
void write_capture_folder(const std::string& dir, const std::string& stem, const std::vector<Image>& pictures,
                          const std::vector<Camera>& cameras);

// `landmarks capture`: the whole synthetic capture of a scan (cameras around its bounding box's centre, one photo
// each) written as photo_NN.png + cameras.json.
void write_synthetic_capture(const Mesh& scan, const Image* diffuse, const std::string& dir,
                             const CaptureOptions& options);
// The same on files: `scan` a scan folder or a mesh file (then `texture` its diffuse map, "" for grey). InvalidInput
// for bad options or an output that would replace an input, before anything is read.
void write_synthetic_capture(const std::string& scan, const std::string& texture, const std::string& dir,
                             const CaptureOptions& options);

}  // namespace bareskin
