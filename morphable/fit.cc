#include "morphable/fit.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <chrono>
#include <cmath>

#include "core/error.h"
#include "core/files.h"
#include "core/svg_chart.h"
#include "morphable/levenberg_marquardt.h"
#include "render/rasterize.h"
#include "render/sh.h"

namespace bareskin {
namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

void LandmarkFitOptions::check() const {
  if (shape_components < 0 || expression_components < 0) {
    throw InvalidInput("", "--shape-components and --expression-components must be >= 0", "");
  }
  if (!(regularisation >= 0)) throw InvalidInput("", "--regularisation must be >= 0", "");
  if (iterations < 1 || iterations > 1000) throw InvalidInput("", "--iterations must lie in [1, 1000]", "");
}

Coefficients to_coefficients(const LandmarkFit& fit) {
  Coefficients c;
  c.alpha = fit.alpha;
  c.beta = fit.beta;
  c.rotation = fit.rotation;
  c.translation = fit.translation;
  return c;
}

LandmarkFit fit_landmarks(const MorphableModel& model, const Eigen::MatrixX2d& target, const Camera& camera,
                          const LandmarkFitOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  options.check();
  if (model.landmark_vertices.size() != 68 || target.rows() != 68) {
    throw InvalidInput("", "the fit needs 68 model landmarks and 68 image landmarks", "");
  }
  if (!target.allFinite()) throw InvalidInput("", "the image landmarks hold NaN or Inf", "");
  const int Ka = std::min<int>(options.shape_components, int(model.shape_basis.rows()));
  const int Kb = std::min<int>(options.expression_components, int(model.expression_basis.rows()));
  const int K = Ka + Kb;
  // The landmark rows of the mean and of the scaled bases: S_k = mean_k + Σ_j α_j σ_j U_j,k + Σ_j β_j σ'_j E_j,k.
  Eigen::MatrixXd mean(68, 3), basis(3 * 68, K);
  for (int k = 0; k < 68; ++k) {
    const int v = model.landmark_vertices[size_t(k)];
    mean.row(k) = model.topology.V.row(v);
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < Ka; ++j) basis(3 * k + c, j) = double(model.shape_basis(j, 3 * v + c)) * model.shape_stddev(j);
      for (int j = 0; j < Kb; ++j) {
        basis(3 * k + c, Ka + j) = double(model.expression_basis(j, 3 * v + c)) * model.expression_stddev(j);
      }
    }
  }
  const int P = 6 + K, M = 2 * 68 + K;
  const auto residuals = [&](const Eigen::VectorXd& x) {
    Eigen::VectorXd r(M);
    const Eigen::Matrix3d R = euler_rotation(x.head<3>());
    const Eigen::VectorXd s = basis * x.tail(K);
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d p = R * (mean.row(k).transpose() + s.segment<3>(3 * k)) + x.segment<3>(3);
      const Eigen::Vector3d q = camera.project(p);
      r(2 * k) = q.x() - target(k, 0);
      r(2 * k + 1) = q.y() - target(k, 1);
    }
    r.tail(K) = std::sqrt(options.regularisation) * x.tail(K);
    return r;
  };
  Eigen::VectorXd x = Eigen::VectorXd::Zero(P);
  if (const LandmarkFit* s = options.start) {
    x.head<3>() = s->rotation;
    x.segment<3>(3) = s->translation;
    for (int j = 0; j < std::min<int>(Ka, int(s->alpha.size())); ++j) x(6 + j) = s->alpha(j);
    for (int j = 0; j < std::min<int>(Kb, int(s->beta.size())); ++j) x(6 + Ka + j) = s->beta(j);
    if (!x.allFinite()) throw InvalidInput("", "the fit's start holds NaN or Inf", "");
  }
  Eigen::VectorXd r = residuals(x);
  LandmarkFit out;
  const auto rms = [&] { return std::sqrt(r.head(2 * 68).squaredNorm() / 68); };
  out.trace.push_back({0, seconds_since(t0), rms()});
  out.iterations = levenberg_marquardt(
      x, r, residuals, [](Eigen::Index p) { return p < 3 ? 1e-6 : 1e-4; },  // radians; mm and standardised α
      options.iterations, [&](int it) { out.trace.push_back({it, seconds_since(t0), rms()}); });
  out.rotation = x.head<3>();
  out.translation = x.segment<3>(3);
  out.alpha = x.segment(6, Ka);
  out.beta = x.tail(Kb);
  out.rms_px = rms();
  return out;
}

void PhotometricFitOptions::check() const {
  if (appearance_components < 0) throw InvalidInput("", "--appearance-components must be >= 0", "");
  if (!(noise > 0) || !(lighting_sd > 0)) throw InvalidInput("", "--colour-noise and --lighting-sd must be > 0", "");
  if (iterations < 1 || iterations > 1000) throw InvalidInput("", "the photometric fit's iterations must lie in [1, 1000]", "");
}

PhotometricFit fit_photometric(const MorphableModel& model, const Mesh& posed, const Camera& camera, const Image& image,
                               const PhotometricFitOptions& options) {
  options.check();
  const auto t0 = std::chrono::steady_clock::now();
  if (image.width != camera.width || image.height != camera.height || image.channels < 3) {
    throw InvalidInput("", "the image must be RGB of the camera's size", "");
  }
  const int R = model.appearance_resolution;
  const int K = std::min<int>(options.appearance_components, int(model.appearance_basis.rows()));
  const RasterOutput r = rasterize_mesh(posed, camera);
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> FUV = posed.FUV, F = posed.F;
  const Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor> UV = posed.UV.cast<float>();
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> N =
      (vertex_normals(posed.V, posed.F) * camera.R.transpose()).cast<float>();
  const std::vector<float> uv = interpolate(r, FUV.data(), UV.data(), 2), nrm = interpolate(r, F.data(), N.data(), 3);
  const Image* mask = options.skin_mask;
  if (mask && (mask->width != camera.width || mask->height != camera.height || mask->channels < 1)) {
    throw InvalidInput("", "the skin mask must be of the image's size", "give a mask of the same width and height");
  }
  std::vector<int64_t> pix;
  for (size_t i = 0; i < r.triangle.size(); ++i)
    if (r.triangle[i] >= 0 && (!mask || mask->pixels[i * size_t(mask->channels)] > 0.5f)) pix.push_back(int64_t(i));
  const Eigen::Index P = Eigen::Index(pix.size());
  if (P < 50 || R == 0) {
    throw InvalidInput("", "the model covers too few pixels" + std::string(mask ? " inside the skin mask" : "") +
                               " (or has no appearance)", "check the landmarks and the mask");
  }
  // Per pixel: observed colour, SH basis, mean albedo and the scaled basis albedos (bilinear in the R x R images).
  Eigen::MatrixXd c(P, 3), Y(P, 9), m(P, 3);
  std::vector<Eigen::MatrixXd> b(3, Eigen::MatrixXd(P, K));
  const auto bilinear = [&](const float* img, double u, double v, int ch) {  // row 0 = v = 1, like the model file
    const double x = std::clamp(u * R - 0.5, 0.0, R - 1.0), y = std::clamp((1 - v) * R - 0.5, 0.0, R - 1.0);
    const int x0 = int(x), y0 = int(y), x1 = std::min(x0 + 1, R - 1), y1 = std::min(y0 + 1, R - 1);
    const double fx = x - x0, fy = y - y0;
    const auto at = [&](int xx, int yy) { return double(img[(size_t(yy) * size_t(R) + size_t(xx)) * 3 + size_t(ch)]); };
    return (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x1, y0)) + fy * ((1 - fx) * at(x0, y1) + fx * at(x1, y1));
  };
  for (Eigen::Index q = 0; q < P; ++q) {
    const size_t i = size_t(pix[size_t(q)]);
    const double u = uv[2 * i], v = uv[2 * i + 1];
    const std::array<double, 9> y = sh_basis(Eigen::Vector3d(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]).normalized());
    for (int k = 0; k < 9; ++k) Y(q, k) = y[size_t(k)];
    for (int ch = 0; ch < 3; ++ch) {
      c(q, ch) = image.pixels[i * size_t(image.channels) + size_t(ch)];
      m(q, ch) = bilinear(model.appearance_mean.data(), u, v, ch);
      for (int k = 0; k < K; ++k) b[size_t(ch)](q, k) = bilinear(model.appearance_basis.row(k).data(), u, v, ch) * model.appearance_stddev(k);
    }
  }
  PhotometricFit out;
  out.pixels = P;
  const auto psnr = [&](double sse) { return 10 * std::log10(1 / std::max(sse / double(3 * P), 1e-20)); };
  out.delta = Eigen::VectorXd::Zero(K);
  Eigen::MatrixXd gamma = Eigen::MatrixXd::Zero(9, 3);
  gamma.row(0).setConstant(kDeep3dAmbient);
  // Gauss-Newton on (δ, γ) together: the albedo-lighting valley is flat, so alternating solves would crawl along it;
  // the joint step with the priors crosses it. Unknowns: δ (K), then γ channel by channel (27).
  Eigen::MatrixXd albedo(P, 3);
  const double prior_delta = options.noise * options.noise;
  const double prior_gamma = options.noise * options.noise / (options.lighting_sd * options.lighting_sd);
  for (int it = 0; it < options.iterations; ++it) {
    for (int ch = 0; ch < 3; ++ch) albedo.col(ch) = m.col(ch) + b[size_t(ch)] * out.delta;
    const Eigen::MatrixXd E = Y * gamma;
    const int U = K + 27;
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(U, U);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(U);
    double sse = 0;
    for (int ch = 0; ch < 3; ++ch) {
      Eigen::MatrixXd J(P, K + 9);  // this channel's residual depends on δ and γ_ch only
      J.leftCols(K) = E.col(ch).asDiagonal() * b[size_t(ch)];
      J.rightCols(9) = albedo.col(ch).asDiagonal() * Y;
      const Eigen::VectorXd r = albedo.col(ch).cwiseProduct(E.col(ch)) - c.col(ch);
      sse += r.squaredNorm();
      const Eigen::MatrixXd JtJ = J.transpose() * J;
      const Eigen::VectorXd Jtr = J.transpose() * r;
      const int o = K + 9 * ch;
      H.topLeftCorner(K, K) += JtJ.topLeftCorner(K, K);
      H.block(0, o, K, 9) += JtJ.topRightCorner(K, 9);
      H.block(o, 0, 9, K) += JtJ.bottomLeftCorner(9, K);
      H.block(o, o, 9, 9) += JtJ.bottomRightCorner(9, 9);
      g.head(K) += Jtr.head(K);
      g.segment(o, 9) += Jtr.tail(9);
    }
    out.trace.push_back({it, seconds_since(t0), psnr(sse)});
    for (int k = 0; k < K; ++k) {
      H(k, k) += prior_delta;
      g(k) += prior_delta * out.delta(k);
    }
    for (int ch = 0; ch < 3; ++ch)
      for (int k = 0; k < 9; ++k) {
        const int o = K + 9 * ch + k;
        H(o, o) += prior_gamma;
        g(o) += prior_gamma * (gamma(k, ch) - (k == 0 ? kDeep3dAmbient : 0.0));
      }
    const Eigen::VectorXd step = H.ldlt().solve(-g);
    out.delta += step.head(K);
    for (int ch = 0; ch < 3; ++ch) gamma.col(ch) += step.segment(K + 9 * ch, 9);
    if (step.norm() < 1e-8) break;
  }
  for (int ch = 0; ch < 3; ++ch) albedo.col(ch) = m.col(ch) + b[size_t(ch)] * out.delta;
  const Eigen::MatrixXd rendered = albedo.cwiseProduct(Y * gamma);
  out.psnr_db = psnr((rendered - c).squaredNorm());
  out.trace.push_back({int(out.trace.size()), seconds_since(t0), out.psnr_db});
  for (int ch = 0; ch < 3; ++ch)
    for (int k = 0; k < 9; ++k) out.gamma[size_t(9 * ch + k)] = gamma(k, ch);
  return out;
}

void write_fit_trace(const std::string& csv_path, const LandmarkFit& fit, const PhotometricFit& photo) {
  std::string csv = "stage,iteration,milliseconds,value,unit\n";
  const std::string stem = csv_path.size() > 4 && csv_path.substr(csv_path.size() - 4) == ".csv"
                               ? csv_path.substr(0, csv_path.size() - 4) : csv_path;
  const auto add = [&](const char* stage, const std::vector<FitTraceStep>& trace, const char* unit, const std::string& title,
                       const std::string& y_label) {
    if (trace.empty()) return;
    ChartSeries series{stage, {}, {}};
    for (const FitTraceStep& t : trace) {
      csv += fmt::format("{},{},{:.3f},{:.6g},{}\n", stage, t.iteration, 1000 * t.seconds, t.value, unit);
      series.x.push_back(1000 * t.seconds);
      series.y.push_back(t.value);
    }
    Chart chart{title, "milliseconds (one marker per iteration)", y_label, {series}};
    chart.log_y = std::string(stage) == "landmarks";
    chart.y_from_zero = false;
    write_file_atomic(stem + "_" + stage + ".svg", svg_line_chart(chart));
  };
  add("landmarks", fit.trace, "px", "Landmark fit (Levenberg-Marquardt)", "landmark RMS (px, log scale)");
  add("photometric", photo.trace, "dB", "Photometric fit (Gauss-Newton on delta, gamma)", "render PSNR (dB)");
  write_file_atomic(csv_path, csv);
}

}  // namespace bareskin
