#include "fitting/view_alignment.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <array>
#include <cmath>

#include "core/error.h"
#include "core/parallel.h"
#include "morphable/fit.h"
#include "render/rasterize.h"
#include "uvtools/unwarp.h"

namespace bareskin::texgen {

void ViewAlignmentOptions::check() const {
  if (rounds < 0 || rounds > 10) throw InvalidInput("--align-views", "must lie in [0, 10]", "e.g. 2");
  if (size < 32 || size > 2048) throw InvalidInput("--align-size", "must lie in [32, 2048]", "e.g. 256");
  if (iterations < 1 || iterations > 100) throw InvalidInput("--align-iterations", "must lie in [1, 100]", "e.g. 8");
  if (!(sharpness >= 0 && sharpness <= 64)) throw InvalidInput("--merge-sharpness", "must lie in [0, 64]", "");
  if (!(landmark_weight >= 0 && landmark_weight <= 1e6))
    throw InvalidInput("--align-landmark-weight", "must lie in [0, 1e6]", "e.g. 1");
  if (!(shape_prior >= 0 && shape_prior <= 1e6)) throw InvalidInput("--align-shape-prior", "must lie in [0, 1e6]", "e.g. 1");
}

namespace {

using Pose = Eigen::Matrix<double, 6, 1>;  // rx, ry, rz (Euler, R = Rz Ry Rx), tx, ty, tz (mm)

Pose pose_of(const Coefficients& c) {
  Pose p;
  p << c.rotation, c.translation;
  return p;
}

// One level of the pyramid: the views' images and, per view, the fitted shape's point and view confidence at each
// texel of the UV layout.
struct Level {
  int size = 0;
  Camera camera;
  std::vector<Image> images;                      // linear RGB, size²
  std::vector<int> texels;                        // in-layout texel indices
  std::vector<std::vector<Eigen::Vector3d>> points;  // [view][j]: object-frame point of texel j
  std::vector<std::vector<float>> confidence;     // [view][j]: cos(view angle) at the landmark pose, 0 unseen
  Eigen::MatrixXd dpoints;                        // [3j + c, k]: d point_j / d α_k (the first view's shape)
};

Level make_level(const MorphableModel& model, const std::vector<Coefficients>& views,
                 const std::vector<const Image*>& images, int size) {
  Level L;
  L.size = size;
  L.camera = view_camera("front", size, Eigen::Vector3d::Zero(), 1000);
  const RasterOutput uv = rasterize_uv(model.topology, size);
  for (int64_t i = 0; i < int64_t(size) * size; ++i)
    if (uv.triangle[size_t(i)] >= 0) L.texels.push_back(int(i));
  for (size_t v = 0; v < views.size(); ++v) {
    const Image& source = *images[v];
    L.images.push_back(resize_square(source.color_space == ColorSpace::sRGB ? to_linear(source) : source, size));
    const Eigen::MatrixX3d V = model.shape(views[v].alpha, views[v].beta);
    std::vector<Eigen::Vector3d> points(L.texels.size());
    for (size_t j = 0; j < L.texels.size(); ++j) {
      const size_t i = size_t(L.texels[j]);
      const int f = uv.triangle[i];
      const double b1 = uv.bary[2 * i], b2 = uv.bary[2 * i + 1];
      points[j] = (1 - b1 - b2) * V.row(model.topology.F(f, 0)).transpose() +
                  b1 * V.row(model.topology.F(f, 1)).transpose() + b2 * V.row(model.topology.F(f, 2)).transpose();
    }
    L.points.push_back(std::move(points));
    UnwarpOptions o;
    o.size = size;
    o.uv_raster = &uv;
    const UnwarpResult seen = unwarp(L.images.back(), posed_mesh(model, views[v]), L.camera, o);
    std::vector<float> c(L.texels.size());
    for (size_t j = 0; j < L.texels.size(); ++j) c[j] = seen.confidence.pixels[size_t(L.texels[j])];
    L.confidence.push_back(std::move(c));
  }
  const Eigen::Index K = model.shape_basis.rows();
  L.dpoints.resize(3 * Eigen::Index(L.texels.size()), K);
  const Eigen::MatrixX3d V0 = model.shape(views[0].alpha, views[0].beta);
  for (Eigen::Index k = 0; k < K; ++k) {
    Eigen::VectorXd a = views[0].alpha;
    if (a.size() < K) a.conservativeResizeLike(Eigen::VectorXd::Zero(K));
    a[k] += 1;
    const Eigen::MatrixX3d D = model.shape(a, views[0].beta) - V0;
    for (size_t j = 0; j < L.texels.size(); ++j) {
      const size_t i = size_t(L.texels[j]);
      const int f = uv.triangle[i];
      const double b1 = uv.bary[2 * i], b2 = uv.bary[2 * i + 1];
      L.dpoints.block(3 * Eigen::Index(j), k, 3, 1) = (1 - b1 - b2) * D.row(model.topology.F(f, 0)).transpose() +
                                                      b1 * D.row(model.topology.F(f, 1)).transpose() +
                                                      b2 * D.row(model.topology.F(f, 2)).transpose();
    }
  }
  return L;
}

// View v's image sampled (bilinear, linear RGB) at its texels' projections under `pose`; black outside the frame and
// where the view does not see the texel.
std::vector<Eigen::Vector3f> sample_view(const Level& L, size_t v, const Pose& pose,
                                         const Eigen::VectorXd* dalpha = nullptr) {
  const Eigen::Matrix3d R = euler_rotation(pose.head<3>());
  const Eigen::Vector3d t = pose.tail<3>();
  const Image& img = L.images[v];
  std::vector<Eigen::Vector3f> out(L.texels.size(), Eigen::Vector3f::Zero());
  parallel_for(0, int64_t(L.texels.size()), [&](int64_t b, int64_t e) {
    for (int64_t j = b; j < e; ++j) {
      if (L.confidence[v][size_t(j)] <= 0) continue;
      Eigen::Vector3d p = L.points[v][size_t(j)];
      if (dalpha) p += L.dpoints.middleRows(3 * j, 3) * *dalpha;
      const Eigen::Vector3d x = L.camera.project(R * p + t);
      const double sx = x.x() - 0.5, sy = x.y() - 0.5;
      if (!(sx >= 0 && sy >= 0 && sx <= L.size - 1 && sy <= L.size - 1)) continue;
      const int x0 = std::min(int(sx), L.size - 2), y0 = std::min(int(sy), L.size - 2);
      const float fx = float(sx - x0), fy = float(sy - y0);
      for (int c = 0; c < 3; ++c)
        out[size_t(j)][c] = (1 - fy) * ((1 - fx) * img.at(x0, y0, c) + fx * img.at(x0 + 1, y0, c)) +
                            fy * ((1 - fx) * img.at(x0, y0 + 1, c) + fx * img.at(x0 + 1, y0 + 1, c));
    }
  }, 4096);
  return out;
}

// The merge of every view but v (confidence^sharpness weights) and its weight per texel (the largest confidence).
void merge_others(const Level& L, const std::vector<std::vector<Eigen::Vector3f>>& colours, size_t v, double sharpness,
                  std::vector<Eigen::Vector3f>& merged, std::vector<float>& weight) {
  merged.assign(L.texels.size(), Eigen::Vector3f::Zero());
  weight.assign(L.texels.size(), 0.f);
  for (size_t j = 0; j < L.texels.size(); ++j) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double total = 0;
    for (size_t u = 0; u < colours.size(); ++u) {
      const float c = L.confidence[u][j];
      if (u == v || c <= 0) continue;
      const double w = std::pow(double(c), sharpness);
      sum += w * colours[u][j].cast<double>();
      total += w;
      weight[j] = std::max(weight[j], c);
    }
    if (total > 0) merged[j] = (sum / total).cast<float>();
  }
}

// Σ_j w_j |c_j − m_j|² with w_j = c_vj · weight_j, and the residual vector (3 per texel) when `r` is given.
double disagreement(const Level& L, size_t v, const std::vector<Eigen::Vector3f>& colours,
                    const std::vector<Eigen::Vector3f>& merged, const std::vector<float>& weight, Eigen::VectorXd* r,
                    double* total_weight = nullptr) {
  double cost = 0, wsum = 0;
  if (r) r->setZero(3 * Eigen::Index(L.texels.size()));
  for (size_t j = 0; j < L.texels.size(); ++j) {
    const double w = double(L.confidence[v][j]) * double(weight[j]);
    if (w <= 0) continue;
    const Eigen::Vector3d d = (colours[j] - merged[j]).cast<double>() * std::sqrt(w);
    if (r) r->segment<3>(3 * Eigen::Index(j)) = d;
    cost += d.squaredNorm();
    wsum += w;
  }
  if (total_weight) *total_weight = wsum;
  return cost;
}

// A view's landmark term: the shape's landmark points (with the detector's offsets), the detected points and their
// weights, in the render camera.
struct Anchor {
  const Camera* camera = nullptr;
  Eigen::Matrix<double, 68, 3> points;
  Eigen::Matrix<double, 68, 2> landmarks;
  Eigen::Matrix<double, 68, 1> weight;
  double scale = 0;  // sqrt(landmark_weight / Σ weight) / 10 px; 0: no term
};

// The residuals of view v at `pose`: the disagreement (scaled by 1 / (0.05 sqrt(W)), W the total weight at the
// start) and, with an anchor, the landmarks' reprojection errors (2 per landmark).
double residuals(const Level& L, size_t v, const Pose& pose, const std::vector<Eigen::Vector3f>& merged,
                 const std::vector<float>& weight, double photo_scale, const Anchor& anchor, Eigen::VectorXd& r) {
  Eigen::VectorXd photo;
  disagreement(L, v, sample_view(L, v, pose), merged, weight, &photo);
  const Eigen::Index n = photo.size();
  r.resize(n + (anchor.scale > 0 ? 136 : 0));
  r.head(n) = photo * photo_scale;
  if (anchor.scale > 0) {
    const Eigen::Matrix3d R = euler_rotation(pose.head<3>());
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d q = anchor.camera->project(R * anchor.points.row(k).transpose() + pose.tail<3>());
      const double s = anchor.scale * std::sqrt(std::max(0.0, anchor.weight(k)));
      r(n + 2 * k) = s * (q.x() - anchor.landmarks(k, 0));
      r(n + 2 * k + 1) = s * (q.y() - anchor.landmarks(k, 1));
    }
  }
  return r.squaredNorm();
}

// Levenberg–Marquardt on view v's pose against a fixed merge of the others; forward-difference Jacobian.
Pose align_one(const Level& L, size_t v, Pose pose, const std::vector<Eigen::Vector3f>& merged,
               const std::vector<float>& weight, int iterations, const Anchor& anchor) {
  const double step[6] = {1e-3, 1e-3, 1e-3, 0.1, 0.1, 0.1};
  double total_weight = 0;
  disagreement(L, v, sample_view(L, v, pose), merged, weight, nullptr, &total_weight);
  if (!(total_weight > 0)) return pose;
  const double photo_scale = 1 / (0.05 * std::sqrt(total_weight));
  Eigen::VectorXd r, r_h;
  double cost = residuals(L, v, pose, merged, weight, photo_scale, anchor, r);
  double lambda = 1e-3;
  for (int it = 0; it < iterations; ++it) {
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(r.size(), 6);
    for (int k = 0; k < 6; ++k) {
      Pose p = pose;
      p[k] += step[k];
      residuals(L, v, p, merged, weight, photo_scale, anchor, r_h);
      J.col(k) = (r_h - r) / step[k];
    }
    const Eigen::Matrix<double, 6, 6> H = J.transpose() * J;
    const Pose g = J.transpose() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 4 && !improved; ++attempt) {
      Eigen::Matrix<double, 6, 6> A = H;
      A.diagonal() += lambda * H.diagonal() + Pose::Constant(1e-9);
      const Pose next = pose - A.ldlt().solve(g);
      Eigen::VectorXd r_next;
      const double c = residuals(L, v, next, merged, weight, photo_scale, anchor, r_next);
      if (c < cost) {
        pose = next, cost = c, r = std::move(r_next), lambda = std::max(1e-6, lambda / 3), improved = true;
      } else {
        lambda *= 8;
      }
    }
    if (!improved) break;
  }
  return pose;
}

// The joint problem of `options.shape`: θ = [Δα (K), the free views' poses (6 each)].
struct ShapeProblem {
  const Level* L = nullptr;
  std::vector<Pose> poses;   // current poses (the fixed view's stays)
  size_t first_free = 0;
  Eigen::VectorXd alpha0;    // the shared α at the start (K); the level's points are its shape's
  Eigen::VectorXd base;      // Δα from the start already found (earlier passes)
  std::vector<Anchor> anchors;
  Eigen::MatrixXd dlandmarks;  // [3k + c, K]: d landmark point / d α
  double photo_scale = 0, prior_scale = 0;
  std::vector<std::array<size_t, 3>> pairs;  // (u, v, j) with both views seeing texel j
  std::vector<double> pair_weight;           // sqrt(c_u c_v)

  Eigen::Index K() const { return alpha0.size(); }
  Eigen::Index parameters() const { return K() + 6 * Eigen::Index(poses.size() - first_free); }
  Pose pose(const Eigen::VectorXd& theta, size_t v) const {
    return v < first_free ? poses[v] : Pose(poses[v] + theta.segment<6>(K() + 6 * Eigen::Index(v - first_free)));
  }
  using Colours = std::vector<std::vector<Eigen::Vector3f>>;  // [view][j]
  // View v's image sampled at its texels under θ (the shared shape moved by base + Δα).
  std::vector<Eigen::Vector3f> sample(const Eigen::VectorXd& theta, size_t v) const {
    const Eigen::VectorXd dalpha = base + theta.head(K());
    return sample_view(*L, v, pose(theta, v), &dalpha);
  }
  Colours sample_all(const Eigen::VectorXd& theta) const {
    Colours colours;
    for (size_t v = 0; v < poses.size(); ++v) colours.push_back(sample(theta, v));
    return colours;
  }
  // The residuals at θ from the views' colours sampled at θ; returns their squared norm.
  double residuals(const Eigen::VectorXd& theta, const Colours& colours, Eigen::VectorXd& r) const {
    const Eigen::VectorXd dalpha = base + theta.head(K());
    const Eigen::Index n = 3 * Eigen::Index(pairs.size());
    r.resize(n + 136 * Eigen::Index(poses.size()) + K());
    r.setZero();
    for (size_t q = 0; q < pairs.size(); ++q) {
      const auto [u, v, j] = pairs[q];
      r.segment<3>(3 * Eigen::Index(q)) = (photo_scale * pair_weight[q]) * (colours[u][j] - colours[v][j]).cast<double>();
    }
    for (size_t v = 0; v < poses.size(); ++v) {
      const Anchor& a = anchors[v];
      if (a.scale <= 0) continue;
      const Pose p = pose(theta, v);
      const Eigen::Matrix3d R = euler_rotation(p.head<3>());
      const Eigen::Index o = n + 136 * Eigen::Index(v);
      for (int k = 0; k < 68; ++k) {
        const Eigen::Vector3d X = a.points.row(k).transpose() + dlandmarks.middleRows(3 * k, 3) * dalpha;
        const Eigen::Vector3d x = a.camera->project(R * X + p.tail<3>());
        const double w = a.scale * std::sqrt(std::max(0.0, a.weight(k)));
        r(o + 2 * k) = w * (x.x() - a.landmarks(k, 0));
        r(o + 2 * k + 1) = w * (x.y() - a.landmarks(k, 1));
      }
    }
    r.tail(K()) = prior_scale * (alpha0 + dalpha);
    return r.squaredNorm();
  }
};

// Levenberg–Marquardt on θ from 0; forward-difference Jacobian. A free view's pose moves only that view's samples,
// so its six columns resample that view alone (the others' colours at θ are reused: the same values, a third of the
// sampling); Δα's columns resample every view.
Eigen::VectorXd solve_shape(const ShapeProblem& P, int iterations) {
  const Eigen::Index m = P.parameters(), K = P.K();
  Eigen::VectorXd theta = Eigen::VectorXd::Zero(m), r, r_h;
  ShapeProblem::Colours colours = P.sample_all(theta);
  double cost = P.residuals(theta, colours, r), lambda = 1e-3;
  for (int it = 0; it < iterations; ++it) {
    Eigen::MatrixXd J(r.size(), m);
    for (Eigen::Index k = 0; k < m; ++k) {
      const Eigen::Index q = k - K;
      const double h = k < K ? 1e-2 : (q % 6 < 3 ? 1e-3 : 0.1);
      Eigen::VectorXd t = theta;
      t[k] += h;
      if (k < K) {
        P.residuals(t, P.sample_all(t), r_h);
      } else {
        const size_t v = P.first_free + size_t(q / 6);
        ShapeProblem::Colours moved = colours;
        moved[v] = P.sample(t, v);
        P.residuals(t, moved, r_h);
      }
      J.col(k) = (r_h - r) / h;
    }
    const Eigen::MatrixXd H = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 4 && !improved; ++attempt) {
      Eigen::MatrixXd A = H;
      A.diagonal() += lambda * H.diagonal() + Eigen::VectorXd::Constant(m, 1e-9);
      const Eigen::VectorXd next = theta - A.ldlt().solve(g);
      ShapeProblem::Colours next_colours = P.sample_all(next);
      Eigen::VectorXd r_next;
      const double c = P.residuals(next, next_colours, r_next);
      if (c < cost) {
        theta = next, cost = c, r = std::move(r_next), colours = std::move(next_colours);
        lambda = std::max(1e-6, lambda / 3), improved = true;
      } else {
        lambda *= 8;
      }
    }
    if (!improved) break;
  }
  return theta;
}

// options.shape: `rounds` passes over the levels of the joint problem; returns Δα and moves the free poses.
Eigen::VectorXd align_shape(const MorphableModel& model, const std::vector<Coefficients>& views,
                            const std::vector<Level>& levels, const std::vector<Anchor>& anchors,
                            const ViewAlignmentOptions& options, std::vector<Pose>& poses) {
  for (const Coefficients& c : views)
    if (c.alpha != views[0].alpha || c.beta != views[0].beta)
      throw InvalidInput("--align-shape", "needs one shape shared by the views", "use --landmark-fit shared-shape");
  const Eigen::Index K = model.shape_basis.rows();
  Eigen::VectorXd alpha = views[0].alpha;
  alpha.conservativeResizeLike(Eigen::VectorXd::Zero(K));
  Eigen::MatrixXd dlandmarks(204, K);
  const Eigen::MatrixX3d V0 = model.shape(alpha, views[0].beta);
  for (Eigen::Index k = 0; k < K; ++k) {
    Eigen::VectorXd a = alpha;
    a[k] += 1;
    const Eigen::MatrixX3d D = model.shape(a, views[0].beta) - V0;
    for (int l = 0; l < 68; ++l) dlandmarks.block(3 * l, k, 3, 1) = D.row(model.landmark_vertices[size_t(l)]).transpose();
  }
  Eigen::VectorXd dalpha = Eigen::VectorXd::Zero(K);
  for (int round = 0; round < options.rounds; ++round)
    for (const Level& L : levels) {
      ShapeProblem P;
      P.L = &L;
      P.poses = poses;
      P.first_free = options.fix_first ? 1 : 0;
      P.alpha0 = alpha;
      P.base = dalpha;
      P.anchors = anchors;
      P.dlandmarks = dlandmarks;
      double wsum = 0;
      for (size_t u = 0; u < poses.size(); ++u)
        for (size_t v = u + 1; v < poses.size(); ++v)
          for (size_t j = 0; j < L.texels.size(); ++j) {
            const double w = double(L.confidence[u][j]) * double(L.confidence[v][j]);
            if (w <= 0) continue;
            P.pairs.push_back({u, v, j});
            P.pair_weight.push_back(std::sqrt(w));
            wsum += w;
          }
      if (!(wsum > 0)) break;
      P.photo_scale = 1 / (0.05 * std::sqrt(wsum));
      P.prior_scale = std::sqrt(options.shape_prior / double(K));
      const Eigen::VectorXd theta = solve_shape(P, options.iterations);
      dalpha += theta.head(K);
      for (size_t v = P.first_free; v < poses.size(); ++v) poses[v] = P.pose(theta, v);
    }
  return dalpha;
}

std::vector<double> rms_disagreement(const Level& L, const std::vector<Pose>& poses, double sharpness) {
  std::vector<std::vector<Eigen::Vector3f>> colours;
  for (size_t v = 0; v < poses.size(); ++v) colours.push_back(sample_view(L, v, poses[v]));
  std::vector<double> rms;
  std::vector<Eigen::Vector3f> merged;
  std::vector<float> weight;
  for (size_t v = 0; v < poses.size(); ++v) {
    merge_others(L, colours, v, sharpness, merged, weight);
    double w = 0;
    const double cost = disagreement(L, v, colours[v], merged, weight, nullptr, &w);
    rms.push_back(w > 0 ? std::sqrt(cost / (3 * w)) : 0.0);
  }
  return rms;
}

}  // namespace

ViewAlignment align_views_photometric(const MorphableModel& model, const std::vector<Coefficients>& views,
                                      const std::vector<const Image*>& images, const Camera& camera,
                                      const ViewAlignmentOptions& options,
                                      const std::vector<LandmarkViewInput>& landmarks,
                                      const Eigen::Matrix<double, 68, 3>* offsets) {
  options.check();
  if (images.size() != views.size()) throw InvalidInput("", "align views: one image per view needed", "");
  for (const Image* img : images)
    if (!img || img->width != camera.width || img->height != camera.height || img->channels < 3)
      throw InvalidInput("", "align views: every image must be an RGB image of the camera's size", "");
  ViewAlignment out;
  out.views = views;
  if (views.size() < 2 || options.rounds == 0) return out;
  // The levels' cameras are the canonical camera at their size: the render's must be that camera too.
  const Camera expected = view_camera("front", camera.width, Eigen::Vector3d::Zero(), 1000);
  BS_CHECK(std::abs(expected.focal - camera.focal) < 1e-9 && expected.t.isApprox(camera.t) && expected.R.isApprox(camera.R),
           "align views: the render camera is not the canonical camera");
  const int fine = std::min(options.size, camera.width);
  std::vector<Level> levels;
  levels.push_back(make_level(model, views, images, std::max(32, fine / 2)));
  levels.push_back(make_level(model, views, images, fine));
  std::vector<Pose> poses;
  for (const Coefficients& c : views) poses.push_back(pose_of(c));
  std::vector<Anchor> anchors(views.size());
  if (options.landmark_weight > 0) {
    if (landmarks.size() != views.size()) throw InvalidInput("", "align views: one landmark set per view needed", "");
    for (size_t v = 0; v < views.size(); ++v) {
      const Eigen::MatrixX3d S = model.shape(views[v].alpha, views[v].beta);
      Anchor& a = anchors[v];
      a.camera = &camera;
      for (int k = 0; k < 68; ++k) {
        a.points.row(k) = S.row(model.landmark_vertices[size_t(k)]);
        if (offsets) a.points.row(k) += offsets->row(k);
      }
      a.landmarks = landmarks[v].landmarks;
      a.weight = landmarks[v].weight.cwiseMax(0);
      if (a.weight.sum() > 0) a.scale = std::sqrt(options.landmark_weight / a.weight.sum()) / 10;
    }
  }
  out.rms_before = rms_disagreement(levels.back(), poses, options.sharpness);
  const Eigen::Index K = model.shape_basis.rows();
  Eigen::VectorXd shape_step = Eigen::VectorXd::Zero(K);
  if (options.shape) shape_step = align_shape(model, views, levels, anchors, options, poses);
  for (int round = 0; round < options.rounds && !options.shape; ++round) {
    for (const Level& L : levels) {
      std::vector<std::vector<Eigen::Vector3f>> colours;
      for (size_t v = 0; v < poses.size(); ++v) colours.push_back(sample_view(L, v, poses[v]));
      std::vector<Pose> next = poses;
      std::vector<Eigen::Vector3f> merged;
      std::vector<float> weight;
      for (size_t v = options.fix_first ? 1 : 0; v < poses.size(); ++v) {
        merge_others(L, colours, v, options.sharpness, merged, weight);
        next[v] = align_one(L, v, poses[v], merged, weight, options.iterations, anchors[v]);
      }
      // Every view moved onto the others at once would overshoot (two views would swap): each takes (n − 1) / n of
      // its step, which for equal weights leaves every view at the views' mean placement.
      const double share = options.fix_first ? 1.0 : double(poses.size() - 1) / double(poses.size());
      for (size_t v = options.fix_first ? 1 : 0; v < poses.size(); ++v) poses[v] += share * (next[v] - poses[v]);
    }
  }
  out.rms_after = rms_disagreement(levels.back(), poses, options.sharpness);
  if (options.shape) {
    Eigen::VectorXd alpha = views[0].alpha;
    alpha.conservativeResizeLike(Eigen::VectorXd::Zero(K));
    for (Coefficients& c : out.views) c.alpha = alpha + shape_step;
  }
  for (size_t v = 0; v < views.size(); ++v) {
    out.views[v].rotation = poses[v].head<3>();
    out.views[v].translation = poses[v].tail<3>();
  }
  return out;
}

}  // namespace bareskin::texgen
