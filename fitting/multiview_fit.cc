#include "fitting/multiview_fit.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "morphable/levenberg_marquardt.h"

namespace bareskin::texgen {

Eigen::Vector3d euler_angles(const Eigen::Matrix3d& R) {
  // R = Rz(c) Ry(b) Rx(a): R20 = −sin b, R21 = cos b sin a, R22 = cos b cos a, R10 = sin c cos b, R00 = cos c cos b.
  const double b = std::asin(std::clamp(-R(2, 0), -1.0, 1.0));
  return {std::atan2(R(2, 1), R(2, 2)), b, std::atan2(R(1, 0), R(0, 0))};
}

Coefficients view_coefficients(const MultiviewLandmarkFit& fit, size_t v) {
  Coefficients c;
  c.alpha = fit.alpha;
  c.beta = fit.beta;
  c.rotation = fit.rotation.at(v);
  c.translation = fit.translation.at(v);
  return c;
}

namespace {

// Bilinear sample of a size² field at pixel position (x, y) (centres at +0.5), clamped at the border.
double sample_field(const std::vector<float>& f, int size, double x, double y) {
  const double fx = std::clamp(x - 0.5, 0.0, size - 1.0), fy = std::clamp(y - 0.5, 0.0, size - 1.0);
  const int x0 = std::min(int(fx), size - 2), y0 = std::min(int(fy), size - 2);
  const double ax = fx - x0, ay = fy - y0;
  const float* r0 = &f[size_t(y0) * size_t(size) + size_t(x0)];
  const float* r1 = r0 + size;
  return (1 - ay) * ((1 - ax) * r0[0] + ax * r0[1]) + ay * ((1 - ax) * r1[0] + ax * r1[1]);
}

MultiviewLandmarkFit fit_multiview(const MorphableModel& model, const std::vector<LandmarkViewInput>& views,
                                   const Camera& camera, const LandmarkFitOptions& options, bool pose_per_view,
                                   const Eigen::Matrix<double, 68, 3>* offsets, const MultiviewLandmarkFit* start,
                                   const std::vector<SilhouetteResiduals>* silhouettes) {
  options.check();
  if (model.landmark_vertices.size() != 68) throw InvalidInput("", "the fit needs a model with 68 landmarks", "");
  if (views.empty()) throw InvalidInput("", "the multi-view fit needs at least one view", "");
  for (const LandmarkViewInput& v : views)
    if (!v.landmarks.allFinite() || !v.weight.allFinite()) throw InvalidInput("", "a view's landmarks hold NaN or Inf", "");
  const int Ka = std::min<int>(options.shape_components, int(model.shape_basis.rows()));
  const int Kb = std::min<int>(options.expression_components, int(model.expression_basis.rows()));
  const int K = Ka + Kb, V = int(views.size());
  // Landmark rows of the mean (plus the detector's offsets) and of the standardised bases.
  Eigen::MatrixXd mean(68, 3), basis(3 * 68, K);
  for (int k = 0; k < 68; ++k) {
    const int v = model.landmark_vertices[size_t(k)];
    mean.row(k) = model.topology.V.row(v);
    if (offsets) mean.row(k) += offsets->row(k);
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < Ka; ++j) basis(3 * k + c, j) = double(model.shape_basis(j, 3 * v + c)) * model.shape_stddev(j);
      for (int j = 0; j < Kb; ++j)
        basis(3 * k + c, Ka + j) = double(model.expression_basis(j, 3 * v + c)) * model.expression_stddev(j);
    }
  }
  // The silhouette vertices' rows of the mean and the bases, view after view.
  std::vector<int> outline;
  if (silhouettes) {
    if (!pose_per_view || silhouettes->size() != views.size())
      throw InvalidInput("", "silhouette residuals need a pose per view and one set per view", "");
    for (const SilhouetteResiduals& sv : *silhouettes) {
      if (!sv.sdf || sv.size < 2 || sv.sdf->size() != size_t(sv.size) * size_t(sv.size))
        throw InvalidInput("", "a silhouette's distance field does not match its size", "");
      for (int i : sv.vertices) {
        if (i < 0 || i >= model.vertices()) throw InvalidInput("", "a silhouette vertex is out of range", "");
        outline.push_back(i);
      }
    }
  }
  const int O = int(outline.size());
  Eigen::MatrixXd outline_mean(std::max(O, 1), 3), outline_basis(3 * std::max(O, 1), K);
  for (int o = 0; o < O; ++o) {
    const int v = outline[size_t(o)];
    outline_mean.row(o) = model.topology.V.row(v);
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < Ka; ++j)
        outline_basis(3 * o + c, j) = double(model.shape_basis(j, 3 * v + c)) * model.shape_stddev(j);
      for (int j = 0; j < Kb; ++j)
        outline_basis(3 * o + c, Ka + j) = double(model.expression_basis(j, 3 * v + c)) * model.expression_stddev(j);
    }
  }
  std::vector<Eigen::Matrix<double, 68, 1>> sqrt_w;
  for (const LandmarkViewInput& v : views) sqrt_w.push_back(v.weight.cwiseMax(0).cwiseSqrt());
  // x = [pose (6) per view, or one pose; α; β]. A shared pose is the head's, seen by view v as Q_v R, Q_v t.
  const int poses = pose_per_view ? V : 1, P = 6 * poses + K, M = 2 * 68 * V + O + K;
  const auto view_pose = [&](const Eigen::VectorXd& x, int v, Eigen::Matrix3d& R, Eigen::Vector3d& t) {
    const int i = pose_per_view ? 6 * v : 0;
    R = euler_rotation(x.segment<3>(i));
    t = x.segment<3>(i + 3);
    if (!pose_per_view) R = (views[size_t(v)].rotation * R).eval(), t = (views[size_t(v)].rotation * t).eval();
  };
  const auto residuals = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd r(M);
    const Eigen::VectorXd s = basis * x.tail(K);
    for (int v = 0; v < V; ++v) {
      Eigen::Matrix3d R;
      Eigen::Vector3d t;
      view_pose(x, v, R, t);
      for (int k = 0; k < 68; ++k) {
        const Eigen::Vector3d q = camera.project(R * (mean.row(k).transpose() + s.segment<3>(3 * k)) + t);
        const double w = sqrt_w[size_t(v)](k);
        r(2 * (68 * v + k)) = w * (q.x() - views[size_t(v)].landmarks(k, 0));
        r(2 * (68 * v + k) + 1) = w * (q.y() - views[size_t(v)].landmarks(k, 1));
      }
    }
    if (O > 0) {
      const Eigen::VectorXd so = outline_basis * x.tail(K);
      int o = 0;
      for (int v = 0; v < V; ++v) {
        const SilhouetteResiduals& sv = (*silhouettes)[size_t(v)];
        Eigen::Matrix3d R;
        Eigen::Vector3d t;
        view_pose(x, v, R, t);
        const double w = std::sqrt(std::max(0.0, sv.weight));
        for (size_t i = 0; i < sv.vertices.size(); ++i, ++o) {
          const Eigen::Vector3d q = camera.project(R * (outline_mean.row(o).transpose() + so.segment<3>(3 * o)) + t);
          r(2 * 68 * V + o) = w * sample_field(*sv.sdf, sv.size, q.x(), q.y());
        }
      }
    }
    r.tail(K) = std::sqrt(options.regularisation) * x.tail(K);
    return r;
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(P);
  if (start) {  // the start's poses (per view) and components
    if (start->alpha.size() != Ka || start->beta.size() != Kb || start->rotation.size() != size_t(poses))
      throw InvalidInput("", "the start fit has other components or views than this fit", "");
    for (int v = 0; v < poses; ++v) {
      x.segment<3>(6 * v) = start->rotation[size_t(v)];
      x.segment<3>(6 * v + 3) = start->translation[size_t(v)];
    }
    x.segment(6 * poses, Ka) = start->alpha;
    x.tail(Kb) = start->beta;
  } else if (pose_per_view) {
    for (int v = 0; v < V; ++v) x.segment<3>(6 * v) = euler_angles(views[size_t(v)].rotation);
  }
  Eigen::VectorXd r = residuals(x);
  MultiviewLandmarkFit out;
  out.iterations = levenberg_marquardt(
      x, r, residuals, [&](Eigen::Index p) { return p < 6 * poses && p % 6 < 3 ? 1e-6 : 1e-4; },  // radians; mm, α
      options.iterations, [](int) {});
  out.alpha = x.segment(6 * poses, Ka);
  out.beta = x.tail(Kb);
  const Eigen::VectorXd s = basis * x.tail(K);
  out.error_px.resize(V, 68);
  out.weight.resize(V, 68);
  for (int v = 0; v < V; ++v) {  // each view's pose, and its unweighted reprojection error over the landmarks used
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    view_pose(x, v, R, t);
    out.rotation.push_back(euler_angles(R));
    out.translation.push_back(t);
    double se = 0;
    int n = 0;
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d q = camera.project(R * (mean.row(k).transpose() + s.segment<3>(3 * k)) + t);
      const double e = (Eigen::Vector2d(q.x(), q.y()) - views[size_t(v)].landmarks.row(k).transpose()).norm();
      out.error_px(v, k) = e;
      out.weight(v, k) = views[size_t(v)].weight(k);
      if (!(views[size_t(v)].weight(k) > 0)) continue;
      se += e * e;
      ++n;
    }
    out.rms_px.push_back(n ? std::sqrt(se / n) : 0.0);
  }
  return out;
}

}  // namespace

MultiviewLandmarkFit fit_landmarks_multiview(const MorphableModel& model, const std::vector<LandmarkViewInput>& views,
                                             const Camera& camera, const LandmarkFitOptions& options,
                                             bool pose_per_view, const Eigen::Matrix<double, 68, 3>* offsets) {
  return fit_multiview(model, views, camera, options, pose_per_view, offsets, nullptr, nullptr);
}

MultiviewLandmarkFit fit_landmarks_multiview(const MorphableModel& model, const std::vector<LandmarkViewInput>& views,
                                             const Camera& camera, const LandmarkFitOptions& options,
                                             const Eigen::Matrix<double, 68, 3>* offsets,
                                             const MultiviewLandmarkFit& start,
                                             const std::vector<SilhouetteResiduals>& silhouettes) {
  return fit_multiview(model, views, camera, options, true, offsets, &start, &silhouettes);
}

MultiviewLandmarkFit fit_landmarks_multiview_robust(const MorphableModel& model, std::vector<LandmarkViewInput> views,
                                                    const Camera& camera, const LandmarkFitOptions& options,
                                                    bool pose_per_view, const Eigen::Matrix<double, 68, 3>* offsets,
                                                    int rounds) {
  if (rounds < 0) throw InvalidInput("", "robust rounds must be >= 0", "");
  std::vector<Eigen::Matrix<double, 68, 1>> given;
  for (const LandmarkViewInput& v : views) given.push_back(v.weight);
  MultiviewLandmarkFit fit = fit_landmarks_multiview(model, views, camera, options, pose_per_view, offsets);
  for (int round = 0; round < rounds; ++round) {
    reweight_landmarks(fit, given, views);
    fit = fit_landmarks_multiview(model, views, camera, options, pose_per_view, offsets);
  }
  return fit;
}

void reweight_landmarks(const MultiviewLandmarkFit& fit, const std::vector<Eigen::Matrix<double, 68, 1>>& given,
                        std::vector<LandmarkViewInput>& views) {
  std::vector<double> errors;
  for (size_t v = 0; v < views.size(); ++v)
    for (int k = 0; k < 68; ++k)
      if (given[v](k) > 0) errors.push_back(fit.error_px(Eigen::Index(v), k));
  if (errors.empty()) return;
  std::nth_element(errors.begin(), errors.begin() + long(errors.size() / 2), errors.end());
  const double scale = 2.385 * std::max(1e-6, 1.4826 * errors[errors.size() / 2]);
  for (size_t v = 0; v < views.size(); ++v)
    for (int k = 0; k < 68; ++k) {
      const double r = fit.error_px(Eigen::Index(v), k) / scale;
      views[v].weight(k) = given[v](k) / (1 + r * r);
    }
}

Eigen::Matrix<double, 68, 3> landmark_offsets(const MorphableModel& model, const Eigen::Matrix<double, 68, 3>& reference,
                                              const Eigen::Matrix<double, 68, 3>& offset) {
  if (model.landmark_vertices.size() != 68) throw InvalidInput("", "the model has no 68 landmarks", "");
  std::vector<int> rows;
  for (int k = 17; k < 68; ++k)
    if (reference.row(k).allFinite() && offset.row(k).allFinite()) rows.push_back(k);
  if (rows.size() < 20)
    throw InvalidInput("", "the landmark calibration has fewer than 20 usable points in 17-67",
                       "make it again with `bareskin landmarks calibrate`");
  Eigen::Matrix3Xd src(3, Eigen::Index(rows.size())), dst(3, Eigen::Index(rows.size()));
  for (size_t i = 0; i < rows.size(); ++i) {
    src.col(Eigen::Index(i)) = (reference.row(rows[i]) + offset.row(rows[i])).transpose();
    dst.col(Eigen::Index(i)) = model.topology.V.row(model.landmark_vertices[size_t(rows[i])]).transpose();
  }
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, true);
  const Eigen::Matrix3d sR = T.topLeftCorner<3, 3>();
  Eigen::Matrix<double, 68, 3> d = Eigen::Matrix<double, 68, 3>::Zero();
  for (int k = 17; k < 68; ++k)  // the jaw (0-16) follows each view's silhouette: no fixed 3D offset describes it
    if (offset.row(k).allFinite()) d.row(k) = -(sR * offset.row(k).transpose()).transpose();
  return d;
}

}  // namespace bareskin::texgen
