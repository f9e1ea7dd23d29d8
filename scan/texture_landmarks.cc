#include "scan/texture_landmarks.h"

#include <algorithm>
#include <cmath>

#include "core/mesh.h"
#include "core/stats.h"
#include "render/rasterize.h"
#include "scan/model_prior.h"

namespace bareskin {

namespace {

// The channel that shows landmark k's feature; false for points the skin's texture does not mark.
bool feature_channel(int k, TextureChannel& channel) {
  if ((k >= 17 && k <= 26) || (k >= 36 && k <= 47)) return channel = TextureChannel::Luminance, true;
  if (k >= 48 && k <= 59) return channel = TextureChannel::Redness, true;
  return false;
}

bool shape_feature(int k) { return k >= 27 && k <= 35; }  // the nose: marked by the surface's curvature

constexpr int kCurvatureSmoothing = 10;  // Taubin steps before the curvature: scan noise of 0.1-0.3 mm drops out

using Rings = TextureLandmarkFinder::Rings;

Rings vertex_rings(const Eigen::Index n, const Eigen::MatrixX3i& F) {
  Rings r;
  r.neighbours.resize(static_cast<size_t>(n));
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      r.neighbours[size_t(F(f, k))].push_back(F(f, (k + 1) % 3));
      r.neighbours[size_t(F(f, k))].push_back(F(f, (k + 2) % 3));
    }
  for (auto& a : r.neighbours) std::sort(a.begin(), a.end()), a.erase(std::unique(a.begin(), a.end()), a.end());
  r.border.assign(static_cast<size_t>(n), 0);
  const Eigen::MatrixX2i edges = boundary_edges(F);
  for (Eigen::Index i = 0; i < edges.rows(); ++i) r.border[size_t(edges(i, 0))] = r.border[size_t(edges(i, 1))] = 1;
  for (size_t i = 0; i < r.border.size(); ++i) r.border[i] |= r.neighbours[i].empty();
  return r;
}

// Mean curvature per vertex (1/mm, umbrella operator, > 0 where the surface bulges along its normals) of V after
// `smoothing` Taubin steps with the border held; 0 on the border.
Eigen::VectorXd mean_curvature(Eigen::MatrixX3d V, const Eigen::MatrixX3i& F, const Rings& r, int smoothing) {
  const Eigen::Index n = V.rows();
  auto umbrella = [&](const Eigen::MatrixX3d& X, Eigen::Index i) {
    Eigen::RowVector3d m = Eigen::RowVector3d::Zero();
    for (const int j : r.neighbours[size_t(i)]) m += X.row(j);
    return Eigen::RowVector3d(m / double(r.neighbours[size_t(i)].size()) - X.row(i));
  };
  for (int it = 0; it < 2 * smoothing; ++it) {
    const double step = it % 2 == 0 ? 0.5 : -0.53;
    Eigen::MatrixX3d next = V;
    for (Eigen::Index i = 0; i < n; ++i)
      if (!r.border[size_t(i)]) next.row(i) += step * umbrella(V, i);
    V = next;
  }
  const Eigen::MatrixX3d N = vertex_normals(V, F);
  Eigen::VectorXd H = Eigen::VectorXd::Zero(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    if (r.border[size_t(i)]) continue;
    double e2 = 0;
    for (const int j : r.neighbours[size_t(i)]) e2 += (V.row(j) - V.row(i)).squaredNorm();
    H[i] = -2 * N.row(i).dot(umbrella(V, i)) / (e2 / double(r.neighbours[size_t(i)].size()));
  }
  return H;
}

// The structure of a surface's mean curvature H (per vertex of the template topology) in the template UV, over the
// texels where `valid` is 1 and no corner is on the border (values over their median magnitude first, so that the
// structure floor means the same as for log-luminance).
Plane curvature_structure(const RasterOutput& raster, const Eigen::MatrixX3i& F, const Rings& r,
                          const Eigen::VectorXd& H, const std::vector<uint8_t>& valid, double sigma, double floor) {
  const int n = raster.width;
  Plane values{n, std::vector<float>(size_t(n) * size_t(n), 0.f)}, mask = values;
  std::vector<double> magnitude;
  for (size_t i = 0; i < values.v.size(); ++i) {
    const int f = raster.triangle[i];
    if (f < 0 || !valid[i] || r.border[size_t(F(f, 0))] || r.border[size_t(F(f, 1))] || r.border[size_t(F(f, 2))]) {
      continue;
    }
    const double b1 = raster.bary[2 * i], b2 = raster.bary[2 * i + 1];
    values.v[i] = float((1 - b1 - b2) * H[F(f, 0)] + b1 * H[F(f, 1)] + b2 * H[F(f, 2)]);
    mask.v[i] = 1;
    magnitude.push_back(std::abs(values.v[i]));
  }
  const double scale = magnitude.empty() ? 1.0 : std::max(1e-9, quantile(magnitude, 0.5));
  for (float& v : values.v) v = float(v / scale);
  return plane_structure(values, mask, sigma, floor);
}

}  // namespace

TextureLandmarkFinder::TextureLandmarkFinder(const TemplateFace& face, const Image& reference,
                                             const TextureRefineOptions& options)
    : face_(face), o_(options) {
  const int n = options.landmark_resolution;
  const double k = double(n) / 512;  // the sizes are given at 512 texels
  o_.resolution = n, o_.window = options.landmark_window * k, o_.smoothing = options.landmark_smoothing * k;
  sigma_ = options.landmark_structure_sigma * k;
  raster_ = rasterize_uv(face.mesh, n);
  layout_ = layout_mask(raster_);
  uv_rows_ = vertex_uv_rows(face.mesh);
  rings_ = vertex_rings(face.mesh.V.rows(), face.mesh.F);
  const Image fixed = resample_square(reference, n);
  luminance_ = texture_structure(fixed, layout_, sigma_, o_.structure_floor, TextureChannel::Luminance);
  redness_ = texture_structure(fixed, layout_, sigma_, o_.structure_floor, TextureChannel::Redness);
  const Eigen::VectorXd H = mean_curvature(face.mesh.V, face.mesh.F, rings_, kCurvatureSmoothing);
  curvature_ = curvature_structure(raster_, face.mesh.F, rings_, H, layout_, sigma_, o_.structure_floor);
  // Shape points' candidates: spread evenly, off the border and its ring (the curvature is not defined there).
  const int shape_points = options.shape_points;  // (spread_vertices takes 0 as "all")
  for (const int v : shape_points > 0 ? spread_vertices(face.mesh.V, face.mesh.F, shape_points) : std::vector<int>{}) {
    bool near_border = rings_.border[size_t(v)] != 0;
    for (const int j : rings_.neighbours[size_t(v)]) near_border |= rings_.border[size_t(j)] != 0;
    if (!near_border) shape_vertices_.push_back(v);
  }
}

TextureLandmarks TextureLandmarkFinder::find(const Eigen::MatrixX3d& V, const Mesh& scan,
                                             const SurfaceLocator& scan_locator, const Image& scan_diffuse) const {
  const Mesh& mesh = face_.mesh;
  std::vector<uint8_t> valid;
  const Image moved = transfer_diffuse(raster_, mesh, V, scan, scan_locator, scan_diffuse, valid);
  TextureLandmarks out;
  out.landmarks.units = "mm";
  out.landmarks.points.resize(68, 3);
  for (int i = 0; i < 68; ++i) out.landmarks.points.row(i) = V.row(face_.landmark_vertices[size_t(i)]);
  std::vector<double> moves;
  // Landmarks `marked` by the flow's features go where it takes their template vertex.
  auto take = [&](const UvFlow& flow, const auto& marked) {
    for (int i = 0; i < 68; ++i) {
      FlowTarget t;
      if (!marked(i) ||
          !flow_target(mesh, V, raster_, flow, scan_locator, uv_rows_, face_.landmark_vertices[size_t(i)], o_, t)) {
        continue;
      }
      out.landmarks.points.row(i) = t.point.transpose();
      out.ids.push_back(i);
      moves.push_back(t.move_mm);
    }
  };
  for (const TextureChannel channel : {TextureChannel::Luminance, TextureChannel::Redness}) {
    const Plane moving = texture_structure(moved, valid, sigma_, o_.structure_floor, channel);
    take(uv_flow(moving, channel == TextureChannel::Luminance ? luminance_ : redness_, valid, o_), [&](int i) {
      TextureChannel c;
      return feature_channel(i, c) && c == channel;
    });
  }
  // The nose is not drawn in the skin but in the shape: the registration's curvature against the template's own. The
  // shape points come from the same flow.
  const Plane shape = curvature_structure(raster_, mesh.F, rings_, mean_curvature(V, mesh.F, rings_, kCurvatureSmoothing),
                                          valid, sigma_, o_.structure_floor);
  const UvFlow shape_flow = uv_flow(shape, curvature_, valid, o_);
  take(shape_flow, shape_feature);
  for (const int v : shape_vertices_) {
    FlowTarget t;
    if (!flow_target(mesh, V, raster_, shape_flow, scan_locator, uv_rows_, v, o_, t)) continue;
    out.shape_vertex.push_back(v);
    out.shape_point.push_back(t.point);
  }
  std::sort(out.ids.begin(), out.ids.end());
  if (!moves.empty()) out.median_move_mm = quantile(moves, 0.5);
  return out;
}

}  // namespace bareskin
