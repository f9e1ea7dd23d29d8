#include "fitting/silhouette_fit.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/parallel.h"
#include "render/rasterize.h"

namespace bareskin::texgen {
namespace {

// Squared distance transform of a sampled function along one line (Felzenszwalb & Huttenlocher 2012): d[q] =
// min_p (q − p)² + f[p]; f = 0 at features, +inf elsewhere.
void distance_1d(const std::vector<float>& f, std::vector<float>& d, std::vector<int>& v, std::vector<float>& z) {
  const int n = int(f.size());
  constexpr float inf = std::numeric_limits<float>::infinity();
  // The lower envelope of the parabolas rooted at the finite samples: v their roots, z the envelope's breaks.
  const auto crossing = [&](int q, int p) {
    return ((f[size_t(q)] + float(q) * float(q)) - (f[size_t(p)] + float(p) * float(p))) / (2.f * float(q - p));
  };
  int k = -1;
  for (int q = 0; q < n; ++q) {
    if (f[size_t(q)] == inf) continue;
    float s = -inf;
    while (k >= 0 && (s = crossing(q, v[size_t(k)])) <= z[size_t(k)]) --k;
    if (k < 0) s = -inf;
    ++k;
    v[size_t(k)] = q;
    z[size_t(k)] = s;
    z[size_t(k) + 1] = inf;
  }
  if (k < 0) {
    std::fill(d.begin(), d.end(), inf);
    return;
  }
  for (int q = 0, j = 0; q < n; ++q) {
    while (z[size_t(j) + 1] < float(q)) ++j;
    const float dq = float(q - v[size_t(j)]);
    d[size_t(q)] = dq * dq + f[size_t(v[size_t(j)])];
  }
}

// Squared Euclidean distance of every pixel to the nearest pixel where feature[i] is set (+inf when none).
std::vector<float> squared_distance(const std::vector<uint8_t>& feature, int size, bool value) {
  constexpr float inf = std::numeric_limits<float>::infinity();
  std::vector<float> g(size_t(size) * size_t(size));
  parallel_for(0, size, [&](int64_t x0, int64_t x1) {  // columns
    std::vector<float> f(static_cast<size_t>(size)), d(static_cast<size_t>(size)), z(static_cast<size_t>(size) + 1);
    std::vector<int> v(static_cast<size_t>(size));
    for (int64_t x = x0; x < x1; ++x) {
      for (int y = 0; y < size; ++y) f[size_t(y)] = (feature[size_t(y) * size_t(size) + size_t(x)] != 0) == value ? 0 : inf;
      distance_1d(f, d, v, z);
      for (int y = 0; y < size; ++y) g[size_t(y) * size_t(size) + size_t(x)] = d[size_t(y)];
    }
  }, 16);
  parallel_for(0, size, [&](int64_t y0, int64_t y1) {  // rows
    std::vector<float> f(static_cast<size_t>(size)), d(static_cast<size_t>(size)), z(static_cast<size_t>(size) + 1);
    std::vector<int> v(static_cast<size_t>(size));
    for (int64_t y = y0; y < y1; ++y) {
      float* row = &g[size_t(y) * size_t(size)];
      std::copy(row, row + size, f.begin());
      distance_1d(f, d, v, z);
      std::copy(d.begin(), d.end(), row);
    }
  }, 16);
  return g;
}

}  // namespace

std::vector<uint8_t> face_silhouette(const Image& render) {
  if (render.width != render.height || render.channels < 1) throw InvalidInput("", "the render is not square", "");
  const int S = render.width, C = render.channels;
  const auto black = [&](size_t i) {
    for (int c = 0; c < std::min(C, 3); ++c)
      if (render.pixels[i * size_t(C) + size_t(c)] > 0) return false;
    return true;
  };
  std::vector<uint8_t> mask(size_t(S) * size_t(S), 1);
  std::vector<size_t> stack;
  const auto visit = [&](size_t i) {
    if (mask[i] && black(i)) mask[i] = 0, stack.push_back(i);
  };
  for (int k = 0; k < S; ++k) {
    visit(size_t(k));
    visit(size_t(S - 1) * size_t(S) + size_t(k));
    visit(size_t(k) * size_t(S));
    visit(size_t(k) * size_t(S) + size_t(S - 1));
  }
  while (!stack.empty()) {
    const size_t i = stack.back();
    stack.pop_back();
    const int y = int(i / size_t(S)), x = int(i % size_t(S));
    if (x > 0) visit(i - 1);
    if (x + 1 < S) visit(i + 1);
    if (y > 0) visit(i - size_t(S));
    if (y + 1 < S) visit(i + size_t(S));
  }
  return mask;
}

std::vector<float> signed_distance(const std::vector<uint8_t>& mask, int size) {
  BS_CHECK(mask.size() == size_t(size) * size_t(size), "signed_distance: mask size");
  const std::vector<float> to_inside = squared_distance(mask, size, true), to_outside = squared_distance(mask, size, false);
  std::vector<float> sdf(mask.size());
  const float far = 2.f * float(size);  // no pixel of the other side: as far as the image reaches
  for (size_t i = 0; i < mask.size(); ++i) {
    if (mask[i]) sdf[i] = std::isfinite(to_outside[i]) ? -(std::sqrt(to_outside[i]) - 0.5f) : -far;
    else sdf[i] = std::isfinite(to_inside[i]) ? std::sqrt(to_inside[i]) - 0.5f : far;
  }
  return sdf;
}

std::vector<int> outline_vertices(const MorphableModel& model, const Coefficients& c, const Camera& camera,
                                  int max_points) {
  const Mesh posed = posed_mesh(model, c);
  const RasterOutput raster = rasterize_mesh(posed, camera);
  const Eigen::Vector3d eye = -camera.R.transpose() * camera.t;
  const Eigen::Index F = posed.F.rows();
  std::vector<int8_t> front(static_cast<size_t>(F));
  for (Eigen::Index f = 0; f < F; ++f) {
    const Eigen::Vector3d a = posed.V.row(posed.F(f, 0)), b = posed.V.row(posed.F(f, 1)), d = posed.V.row(posed.F(f, 2));
    front[size_t(f)] = (b - a).cross(d - a).dot(eye - a) > 0;
  }
  // Each undirected edge with its triangles' facings: sorted, a run of equal edges is one edge; a border edge has one
  // triangle, a contour edge a front- and a back-facing one.
  std::vector<std::pair<int64_t, int8_t>> edges;
  edges.reserve(size_t(3 * F));
  const int64_t nv = posed.V.rows();
  for (Eigen::Index f = 0; f < F; ++f)
    for (int k = 0; k < 3; ++k) {
      const int a = posed.F(f, k), b = posed.F(f, (k + 1) % 3);
      edges.push_back({int64_t(std::min(a, b)) * nv + std::max(a, b), front[size_t(f)]});
    }
  std::sort(edges.begin(), edges.end());
  std::vector<uint8_t> candidate(size_t(posed.V.rows()), 0);
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    int facings = 0;
    for (; j < edges.size() && edges[j].first == edges[i].first; ++j) facings |= edges[j].second ? 1 : 2;
    if (j - i == 1 || facings == 3)
      candidate[size_t(edges[i].first / nv)] = candidate[size_t(edges[i].first % nv)] = 1;
    i = j;
  }
  std::vector<int> out;
  const int W = raster.width, H = raster.height, r = 2;
  for (Eigen::Index i = 0; i < posed.V.rows(); ++i) {
    if (!candidate[size_t(i)]) continue;
    const Eigen::Vector3d q = camera.project(posed.V.row(i).transpose());
    const int x = int(std::floor(q.x())), y = int(std::floor(q.y()));
    if (x < r || y < r || x >= W - r || y >= H - r) continue;
    bool background = false;
    for (int dy = -r; dy <= r && !background; ++dy)
      for (int dx = -r; dx <= r && !background; ++dx)
        background = raster.triangle[size_t(y + dy) * size_t(W) + size_t(x + dx)] < 0;
    if (background) out.push_back(int(i));
  }
  if (max_points > 0 && int(out.size()) > max_points) {
    std::vector<int> kept;
    const double step = double(out.size()) / max_points;
    for (int k = 0; k < max_points; ++k) kept.push_back(out[size_t(k * step)]);
    out.swap(kept);
  }
  return out;
}

namespace {

// A view whose landmarks the shared shape cannot follow at all (face-api collapsed on it: its median reprojection error
// over 3x the median of the views' medians) keeps none of them: its pose comes from the best view through the rig
// (R_v = Q_v Q_b^T R_b, t_v = Q_v Q_b^T t_b), and its outline alone aligns it.
bool drop_lost_views(MultiviewLandmarkFit& fit, std::vector<LandmarkViewInput>& views,
                     std::vector<Eigen::Matrix<double, 68, 1>>& given) {
  const size_t V = views.size();
  if (V < 2) return false;
  std::vector<double> median(V, -1);  // -1: a view without landmarks (dropped before)
  std::vector<double> usable;
  for (size_t v = 0; v < V; ++v) {
    std::vector<double> e;
    for (int k = 0; k < 68; ++k)
      if (given[v](k) > 0) e.push_back(fit.error_px(Eigen::Index(v), k));
    if (e.empty()) continue;
    std::nth_element(e.begin(), e.begin() + long(e.size() / 2), e.end());
    median[v] = e[e.size() / 2];
    usable.push_back(median[v]);
  }
  if (usable.size() < 2) return false;
  std::sort(usable.begin(), usable.end());
  const double typical = usable[(usable.size() - 1) / 2];  // the lower median: with two views, the better one
  size_t best = V;
  for (size_t v = 0; v < V; ++v)
    if (median[v] >= 0 && (best == V || median[v] < median[best])) best = v;
  bool dropped = false;
  for (size_t v = 0; v < V; ++v) {
    if (median[v] < 0 || !(median[v] > 3 * typical) || v == best) continue;
    dropped = true;
    const Eigen::Matrix3d rig = views[v].rotation * views[best].rotation.transpose();
    fit.rotation[v] = euler_angles(rig * euler_rotation(fit.rotation[best]));
    fit.translation[v] = rig * fit.translation[best];
    views[v].weight.setZero();
    given[v].setZero();
  }
  return dropped;
}

}  // namespace

void SilhouetteFitOptions::check() const {
  if (rounds < 0 || rounds > 10) throw InvalidInput("--silhouette-rounds", "must lie in [0, 10]", "e.g. 2");
  if (!(weight >= 0 && weight <= 1000)) throw InvalidInput("--silhouette-weight", "must lie in [0, 1000]", "e.g. 1");
  if (max_points < 8 || max_points > 100000) throw InvalidInput("silhouette fit", "its outline point count must lie in [8, 100000]", "");
}

MultiviewLandmarkFit refine_with_silhouettes(const MorphableModel& model, std::vector<LandmarkViewInput> views,
                                             const std::vector<const Image*>& renders, const Camera& camera,
                                             const LandmarkFitOptions& options,
                                             const Eigen::Matrix<double, 68, 3>* offsets, MultiviewLandmarkFit fit,
                                             const SilhouetteFitOptions& silhouette, bool robust) {
  silhouette.check();
  if (renders.size() != views.size()) throw InvalidInput("", "one render per view is needed", "");
  std::vector<std::vector<float>> sdf;
  for (const Image* render : renders) {
    if (render->width != camera.width || render->height != camera.height)
      throw InvalidInput("", "a render's size differs from the camera's", "");
    sdf.push_back(signed_distance(face_silhouette(*render), render->width));
  }
  std::vector<Eigen::Matrix<double, 68, 1>> given;
  for (const LandmarkViewInput& v : views) given.push_back(v.weight);
  drop_lost_views(fit, views, given);
  for (int round = 0, rounds = silhouette.rounds; round < rounds; ++round) {
    if (robust) reweight_landmarks(fit, given, views);
    std::vector<SilhouetteResiduals> terms(views.size());
    for (size_t v = 0; v < views.size(); ++v) {
      terms[v].sdf = &sdf[v];
      terms[v].size = renders[v]->width;
      terms[v].vertices = outline_vertices(model, view_coefficients(fit, v), camera, silhouette.max_points);
      terms[v].weight = silhouette.weight * 68.0 / double(std::max<size_t>(1, terms[v].vertices.size()));
    }
    fit = fit_landmarks_multiview(model, views, camera, options, offsets, fit, terms);
    // Once the outlines hold the poses, a view whose landmarks collapsed stands out; it gets a round without them.
    if (drop_lost_views(fit, views, given) && round + 1 == rounds && rounds <= silhouette.rounds) ++rounds;
  }
  return fit;
}

}  // namespace bareskin::texgen
