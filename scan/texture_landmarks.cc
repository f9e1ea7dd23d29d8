#include "scan/texture_landmarks.h"

#include <algorithm>
#include <cmath>

#include "core/stats.h"
#include "render/rasterize.h"

namespace bareskin {

namespace {

// The channel that shows landmark k's feature; false for points the skin's texture does not mark.
bool feature_channel(int k, TextureChannel& channel) {
  if ((k >= 17 && k <= 26) || (k >= 36 && k <= 47)) return channel = TextureChannel::Luminance, true;
  if (k >= 48 && k <= 59) return channel = TextureChannel::Redness, true;
  return false;
}

}  // namespace

TextureLandmarks texture_landmarks(const TemplateFace& face, const Eigen::MatrixX3d& V, const Mesh& scan,
                                   const SurfaceLocator& scan_locator, const Image& scan_diffuse,
                                   const Image& reference, const TextureRefineOptions& options) {
  const Mesh& mesh = face.mesh;
  const int n = options.landmark_resolution;
  TextureRefineOptions o = options;
  const double k = double(n) / 512;  // the sizes are given at 512 texels
  o.resolution = n, o.window = options.landmark_window * k, o.smoothing = options.landmark_smoothing * k;
  const double sigma = options.landmark_structure_sigma * k;
  const RasterOutput raster = rasterize_uv(mesh, n);
  std::vector<uint8_t> valid;
  const Image moved = transfer_diffuse(raster, mesh, V, scan, scan_locator, scan_diffuse, valid);
  std::vector<uint8_t> reference_valid(valid.size(), 0);
  for (size_t i = 0; i < valid.size(); ++i) {
    reference_valid[i] = raster.triangle[i] >= 0;
    valid[i] = valid[i] && reference_valid[i];
  }
  const Image fixed = resample_square(reference, n);
  const std::vector<int> uv_rows = vertex_uv_rows(mesh);
  TextureLandmarks out;
  out.landmarks.units = "mm";
  out.landmarks.points.resize(68, 3);
  for (int i = 0; i < 68; ++i) out.landmarks.points.row(i) = V.row(face.landmark_vertices[size_t(i)]);
  std::vector<double> moves;
  for (const TextureChannel channel : {TextureChannel::Luminance, TextureChannel::Redness}) {
    const UvFlow flow = uv_flow(texture_structure(moved, valid, sigma, o.structure_floor, channel),
                                texture_structure(fixed, reference_valid, sigma, o.structure_floor, channel), valid, o);
    for (int i = 0; i < 68; ++i) {
      TextureChannel wanted;
      FlowTarget t;
      if (!feature_channel(i, wanted) || wanted != channel ||
          !flow_target(mesh, V, raster, flow, scan_locator, uv_rows, face.landmark_vertices[size_t(i)], o, t)) {
        continue;
      }
      out.landmarks.points.row(i) = t.point.transpose();
      out.ids.push_back(i);
      moves.push_back(t.move_mm);
    }
  }
  std::sort(out.ids.begin(), out.ids.end());
  if (!moves.empty()) out.median_move_mm = quantile(moves, 0.5);
  return out;
}

}  // namespace bareskin
