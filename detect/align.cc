#include "detect/align.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"
#include "render/camera.h"

namespace bareskin::detect {

FivePoints five_points(const Landmarks68& lm) {
  FivePoints p;
  p.row(0) = lm.middleRows(36, 6).colwise().mean();
  p.row(1) = lm.middleRows(42, 6).colwise().mean();
  p.row(2) = lm.row(30);
  p.row(3) = lm.row(48);
  p.row(4) = lm.row(54);
  return p;
}

const FivePoints& standard_five_points() {
  // standard_five_points_from(the 65,019-vertex template's landmarks.json): the template built by `bareskin template`
  // with its defaults; the test checks these against the test template.
  static const FivePoints standard = (FivePoints() << 89.6503, 96.3312,  //
                                      166.3497, 96.3312,                  //
                                      128.0000, 133.6039,                 //
                                      90.8026, 180.7979,                  //
                                      165.1974, 180.7979)
                                         .finished();
  return standard;
}

FivePoints standard_five_points_from(const std::vector<Eigen::Vector3d>& landmarks3d) {
  if (landmarks3d.size() != 68)
    throw InvalidInput("", "the standard face needs 68 landmarks, got " + std::to_string(landmarks3d.size()),
                       "give iBUG-68 landmarks");
  const Camera camera = view_camera("front", kAlignedSize, Eigen::Vector3d::Zero(), 1000);
  Landmarks68 projected;
  for (int i = 0; i < 68; ++i) projected.row(i) = camera.project(landmarks3d[i]).head<2>().transpose();
  const FivePoints p = five_points(projected);
  // Mirror about x = size/2: the left eye ↔ the right eye, mouth corners likewise, the nose onto itself.
  const int mirror[5] = {1, 0, 2, 4, 3};
  FivePoints symmetric;
  for (int i = 0; i < 5; ++i) {
    const Eigen::RowVector2d m(kAlignedSize - p(mirror[i], 0), p(mirror[i], 1));
    symmetric.row(i) = 0.5 * (p.row(i) + m);
  }
  return symmetric;
}

Eigen::Matrix<double, 2, 3> Similarity::matrix() const {
  Eigen::Matrix<double, 2, 3> m;
  m << scale, 0, translation.x(), 0, scale, translation.y();
  return m;
}

Similarity fit_scale_translation(const FivePoints& from, const FivePoints& to) {
  if (!from.allFinite() || !to.allFinite())
    throw InvalidInput("", "alignment: a landmark is not a finite number", "check the detector's output");
  const Eigen::RowVector2d from_mean = from.colwise().mean(), to_mean = to.colwise().mean();
  const FivePoints a = from.rowwise() - from_mean, b = to.rowwise() - to_mean;
  const double spread = a.squaredNorm();
  if (!(spread > 1e-12))
    throw InvalidInput("", "alignment: the five landmarks coincide", "give landmarks of a face (eyes, nose, mouth)");
  Similarity s;
  s.scale = (a.array() * b.array()).sum() / spread;
  if (!(s.scale > 0))
    throw InvalidInput("", "alignment: the landmarks are mirrored or collapsed (scale " + std::to_string(s.scale) + ")",
                       "give iBUG-68 landmarks in image pixels");
  s.translation = (to_mean - s.scale * from_mean).transpose();
  return s;
}

Similarity alignment(const Landmarks68& landmarks) {
  return fit_scale_translation(five_points(landmarks), standard_five_points());
}

Image warp_aligned(const Image& photo, const Similarity& similarity, int size) {
  BS_CHECK(size > 0 && similarity.scale > 0, "warp_aligned: bad size or scale");
  Image out(size, size, photo.channels, photo.color_space);
  const int c = photo.channels;
  for (int y = 0; y < size; ++y) {
    for (int x = 0; x < size; ++x) {
      const Eigen::Vector2d p = similarity.inverse({x + 0.5, y + 0.5});
      const double fx = p.x() - 0.5, fy = p.y() - 0.5;  // in pixel-index units (centres at integers)
      const double x0 = std::floor(fx), y0 = std::floor(fy);
      if (!(x0 >= -1 && y0 >= -1 && x0 < photo.width && y0 < photo.height)) continue;
      const float wx = float(fx - x0), wy = float(fy - y0);
      const int ix = int(x0), iy = int(y0);
      float* dst = &out.pixels[out.index(x, y)];
      const auto add = [&](int sx, int sy, float w) {
        if (w == 0.f || sx < 0 || sy < 0 || sx >= photo.width || sy >= photo.height) return;  // black outside
        const float* src = &photo.pixels[photo.index(sx, sy)];
        for (int k = 0; k < c; ++k) dst[k] += w * src[k];
      };
      add(ix, iy, (1 - wx) * (1 - wy));
      add(ix + 1, iy, wx * (1 - wy));
      add(ix, iy + 1, (1 - wx) * wy);
      add(ix + 1, iy + 1, wx * wy);
    }
  }
  return out;
}

Landmarks68 transform(const Similarity& similarity, const Landmarks68& landmarks) {
  Landmarks68 out;
  for (int i = 0; i < 68; ++i) out.row(i) = similarity.apply(landmarks.row(i).transpose()).transpose();
  return out;
}

void check_photo(const Image& photo, const std::string& source) {
  if (photo.channels < 3) throw InvalidInput(source, "is not an RGB image", "give a colour photo");
  if (std::min(photo.width, photo.height) < kMinPhotoSide)
    throw InvalidInput(source, "is " + std::to_string(photo.width) + "x" + std::to_string(photo.height) +
                                   " pixels; a face photo needs at least " + std::to_string(kMinPhotoSide) +
                                   " on its shorter side",
                       "give the full-size photo, not a thumbnail (faces are found from about 80 px)");
}

}  // namespace bareskin::detect
