// Deep3DFaceRecon's 5-point alignment of a face image to the 256² canonical frame, shared by every side that feeds
// aligned faces to a network (texgen faces, ingest, recon, de-makeup, run). Eigen only, no Torch.
//
// The five points come from iBUG-68: the eye centres (means of 36–41 and 42–47), the nose tip (30) and the mouth
// corners (48, 54). A scale s and a translation t (no rotation: Deep3DFaceRecon leaves the roll in the coefficients)
// are fitted by least squares, Σ_i |s p_i + t − q_i|², to a fixed standard face q in the 256² frame, and the photo is
// resampled (bilinear) so that aligned(x) = photo((x − t) / s).
//
// The standard face is our template's landmarks seen by the canonical camera view_camera("front", 256, {0,0,0}, 1000)
// (render/camera.h), made left/right symmetric: a face at the model's origin with no rotation renders onto it, so an
// aligned photo and an aligned render agree. Pixel coordinates have their origin at the top-left corner of the
// top-left pixel (its centre at 0.5, 0.5), as the detector and the rasterizer use.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "core/image.h"

namespace bareskin::detect {

constexpr int kAlignedSize = 256;

using FivePoints = Eigen::Matrix<double, 5, 2>;  // left eye, right eye (image left to right), nose tip, mouth corners
using Landmarks68 = Eigen::Matrix<double, 68, 2>;

// The five points of 68 iBUG landmarks (pixels).
FivePoints five_points(const Landmarks68& landmarks);

// The standard face in the 256² frame (constants; see standard_five_points_from).
const FivePoints& standard_five_points();

// The standard face as derived: 68 3D landmarks (mm, model frame) through the canonical 256² camera, then averaged
// with their mirror image about the vertical centre line. standard_five_points() is this for the 65k template.
FivePoints standard_five_points_from(const std::vector<Eigen::Vector3d>& landmarks3d);

// x_aligned = scale · x_photo + translation (pixels).
struct Similarity {
  double scale = 1;
  Eigen::Vector2d translation = Eigen::Vector2d::Zero();

  Eigen::Vector2d apply(const Eigen::Vector2d& photo) const { return scale * photo + translation; }
  Eigen::Vector2d inverse(const Eigen::Vector2d& aligned) const { return (aligned - translation) / scale; }
  // [[s, 0, tx], [0, s, ty]]: the "similarity" stored with aligned samples.
  Eigen::Matrix<double, 2, 3> matrix() const;
};

// The least-squares scale + translation taking `from` onto `to`. InvalidInput for non-finite points or points that
// all coincide (no scale can be fitted).
Similarity fit_scale_translation(const FivePoints& from, const FivePoints& to);

// The alignment of a face with these 68 landmarks (photo pixels): five_points → standard_five_points().
Similarity alignment(const Landmarks68& landmarks);

// The photo resampled into the size² aligned frame (bilinear; black outside the photo). Any channel count and
// colour space (kept); resample sRGB images as they are, like Deep3DFaceRecon does.
Image warp_aligned(const Image& photo, const Similarity& similarity, int size = kAlignedSize);

// The smallest photo `recon`, `run` and `demakeup` take: its shorter side in pixels (the detector finds faces from
// about 80 px; a thumbnail holds none it could align).
constexpr int kMinPhotoSide = 64;
// InvalidInput naming `source` for a photo with fewer than 3 channels or a side below kMinPhotoSide, one line saying
// what to give instead.
void check_photo(const Image& photo, const std::string& source);

// A face found in a photo: the detector's score and its 68 landmarks (pixels).
struct PhotoFace {
  double score = 0;
  Landmarks68 points = Landmarks68::Zero();
};
// A face detector the command passes in to the geometry side (face-api's networks on the Torch side,
// apps/detector.h): the faces of an sRGB-encoded RGB image (values in [0, 1]), best first; empty when none is found.
using PhotoDetector = std::function<std::vector<PhotoFace>(const Image& photo)>;

// Landmarks moved by the similarity (e.g. detected photo landmarks into the aligned frame).
Landmarks68 transform(const Similarity& similarity, const Landmarks68& landmarks);

}  // namespace bareskin::detect
