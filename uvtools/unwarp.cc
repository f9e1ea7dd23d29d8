#include "uvtools/unwarp.h"

#include <atomic>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "render/rasterize.h"

namespace bareskin {

void UnwarpOptions::check() const {
  if (size < 1 || size > 16384) throw InvalidInput("", "--size must lie in [1, 16384]", "");
  if (!(depth_tolerance > 0)) throw InvalidInput("--depth-tolerance", "must be > 0 mm", "e.g. --depth-tolerance 1");
}

UnwarpResult unwarp(const Image& image, const Mesh& mesh, const Camera& camera, const UnwarpOptions& options) {
  options.check();
  if (!mesh.has_uv()) throw InvalidInput("", "the mesh has no UVs to unwarp into", "give a mesh with UVs");
  if (image.width != camera.width || image.height != camera.height) {
    throw InvalidInput("", "the image is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                               ", the camera " + std::to_string(camera.width) + "x" + std::to_string(camera.height),
                       "give the image the camera was fitted to");
  }
  BS_CHECK(!options.inside || (options.inside->width == image.width && options.inside->height == image.height &&
                               options.inside->channels == 1),
           "unwarp: the inside mask must be one channel at the image's size");
  const Image lin = image.color_space == ColorSpace::sRGB ? to_linear(image) : image;

  // The depth buffer seen from the camera.
  const RasterOutput view = rasterize_mesh(mesh, camera);

  RasterOutput own_uv;
  const RasterOutput& uv = given_or_own_uv(options.uv_raster, mesh, options.size, own_uv);
  const Eigen::MatrixX3d N = vertex_normals(mesh.V, mesh.F);
  const Eigen::Vector3d centre = -camera.R.transpose() * camera.t;           // pinhole: the camera's position
  const Eigen::Vector3d toward = camera.R.transpose() * Eigen::Vector3d::UnitZ();  // weak perspective: its direction
  const bool pinhole = camera.model == Camera::Model::Pinhole;

  UnwarpResult out;
  const int S = options.size;
  out.colour = Image(S, S, 3, ColorSpace::Linear);
  out.confidence = Image(S, S, 1, ColorSpace::Data);
  std::atomic<int64_t> seen{0}, in_layout{0};
  parallel_for(0, int64_t(S) * S, [&](int64_t b, int64_t e) {
    int64_t s = 0, l = 0;
    for (int64_t i = b; i < e; ++i) {
      const int32_t f = uv.triangle[size_t(i)];
      if (f < 0) continue;
      ++l;
      const double w[3] = {1.0 - uv.bary[2 * size_t(i)] - uv.bary[2 * size_t(i) + 1], uv.bary[2 * size_t(i)],
                           uv.bary[2 * size_t(i) + 1]};
      Eigen::Vector3d P = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) {
        P += w[k] * mesh.V.row(mesh.F(f, k)).transpose();
        n += w[k] * N.row(mesh.F(f, k)).transpose();
      }
      const Eigen::Vector3d p = camera.project(P);
      if (!(p.x() >= 0 && p.x() < camera.width && p.y() >= 0 && p.y() < camera.height)) continue;
      const double cosine = n.normalized().dot(pinhole ? (centre - P).normalized() : toward);
      if (cosine <= 0) continue;
      // Seen when the depth buffer agrees: within the tolerance plus what the surface's slope spans in one pixel
      // (at grazing angles the depth changes by footprint x tan(angle) from one pixel to the next).
      const size_t pixel = size_t(int(p.y())) * size_t(camera.width) + size_t(int(p.x()));
      const double footprint = pinhole ? p.z() / camera.focal : 1 / camera.scale;  // mm per pixel
      const double slope = std::min(20.0, std::sqrt(std::max(0.0, 1 - cosine * cosine)) / std::max(cosine, 0.05));
      if (!(std::abs(p.z() - view.depth[pixel]) <= options.depth_tolerance + 1.5 * footprint * slope)) continue;
      const Eigen::Vector2d at(p.x() / camera.width, 1 - p.y() / camera.height);
      if (options.inside && sample_bilinear(*options.inside, at)[0] < 0.999f) continue;
      const Eigen::Vector3f c = sample_bilinear(lin, at);
      for (int k = 0; k < 3; ++k) out.colour.pixels[3 * size_t(i) + size_t(k)] = c[k];
      out.confidence.pixels[size_t(i)] = float(cosine);
      ++s;
    }
    seen += s;
    in_layout += l;
  }, 4096);
  out.seen = seen;
  out.in_layout = in_layout;
  return out;
}

}  // namespace bareskin
