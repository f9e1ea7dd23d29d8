#include "morphable/metrics.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "core/error.h"
#include "core/files.h"
#include "core/parallel.h"
#include "core/svg_chart.h"
#include "morphable/build.h"

namespace bareskin {
namespace {

// Gram matrices of the centred data restricted to each region's coordinates (n x n each).
std::vector<Eigen::MatrixXd> region_grams(const RowMatrixXf& X, const std::vector<uint8_t>& vertex_region, int regions) {
  const Eigen::Index n = X.rows(), V = X.cols() / 3;
  constexpr Eigen::Index kVertices = 1024;
  const Eigen::Index blocks = (V + kVertices - 1) / kVertices;
  const int64_t parts = std::min<int64_t>(blocks, 32);
  std::vector<std::vector<Eigen::MatrixXd>> partial(
      static_cast<size_t>(parts), std::vector<Eigen::MatrixXd>(static_cast<size_t>(regions), Eigen::MatrixXd::Zero(n, n)));
  parallel_for(0, parts, [&](int64_t p0, int64_t p1) {
    for (int64_t p = p0; p < p1; ++p) {
      for (Eigen::Index b = p * blocks / parts; b < (p + 1) * blocks / parts; ++b) {
        const Eigen::Index v0 = b * kVertices, w = std::min(kVertices, V - v0);
        for (int r = 0; r < regions; ++r) {
          std::vector<Eigen::Index> cols;
          for (Eigen::Index v = v0; v < v0 + w; ++v)
            if (vertex_region[size_t(v)] == r)
              for (int c = 0; c < 3; ++c) cols.push_back(3 * v + c);
          if (cols.empty()) continue;
          Eigen::MatrixXd B(n, Eigen::Index(cols.size()));
          for (size_t k = 0; k < cols.size(); ++k) B.col(Eigen::Index(k)) = X.col(cols[k]).cast<double>();
          B.rowwise() -= B.colwise().mean();
          partial[size_t(p)][size_t(r)].selfadjointView<Eigen::Lower>().rankUpdate(B);
        }
      }
    }
  }, 1);
  std::vector<Eigen::MatrixXd> G(static_cast<size_t>(regions), Eigen::MatrixXd::Zero(n, n));
  for (const auto& part : partial)
    for (int r = 0; r < regions; ++r) G[size_t(r)] += part[size_t(r)];
  for (auto& g : G) g = g.selfadjointView<Eigen::Lower>();
  return G;
}

std::vector<int> component_grid(int max_k) {
  std::vector<int> k;
  for (int c = 1; c <= max_k; ++c) {
    if (c <= 10 || (c <= 30 && c % 5 == 0) || (c <= 100 && c % 10 == 0) || c % 20 == 0 || c == max_k) k.push_back(c);
  }
  return k;
}

}  // namespace

void MetricsOptions::check() const {
  if (samples < 1 || max_components < 1 || max_held_out < 1) {
    throw InvalidInput("", "--samples, --max-components and --max-held-out must be >= 1", "");
  }
}

void EvaluateModelOptions::check() const {
  if (model.empty() || registered.empty())
    throw InvalidInput("mm-eval", "needs the model and its registered subjects", "give --model and --registered");
  metrics.check();
}

ModelMetrics model_metrics(const RowMatrixXf& X, const std::vector<uint8_t>& vertex_region,
                           const std::vector<std::string>& region_names, const MetricsOptions& options) {
  options.check();
  const Eigen::Index n = X.rows(), V = X.cols() / 3;
  if (n < 4) throw InvalidInput("", "model metrics need at least 4 subjects, got " + std::to_string(n), "add subjects");
  if (Eigen::Index(vertex_region.size()) != V) throw InvalidInput("", "vertex regions do not match the shapes", "");
  const int regions = int(region_names.size());
  std::vector<double> region_vertices(size_t(regions), 0.0);
  for (uint8_t r : vertex_region) {
    if (r >= regions) throw InvalidInput("", "a vertex region index is out of range", "");
    region_vertices[r] += 1;
  }
  const std::vector<Eigen::MatrixXd> Gr = region_grams(X, vertex_region, regions);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, n);
  for (const auto& g : Gr) G += g;

  ModelMetrics out;
  out.subjects = int(n);
  out.regions = region_names;
  out.components = component_grid(std::min<int>(options.max_components, int(n) - 2));
  const size_t K = out.components.size();

  // Compactness and specificity: the full model's eigen-decomposition.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(G);
  const Eigen::VectorXd lambda = eig.eigenvalues().reverse().cwiseMax(0.0);
  const Eigen::MatrixXd U = eig.eigenvectors().rowwise().reverse();
  if (!(lambda.sum() > 1e-20)) throw InvalidInput("", "every subject is the same (no variance)", "give distinct subjects");
  for (int k : out.components) out.compactness.push_back(lambda.head(k).sum() / lambda.sum());
  // Training coefficients a_jl = sqrt(lambda_l) U_jl; |x_j - mean|^2 = G_jj.
  const int kmax = out.components.back();
  const Eigen::MatrixXd A = U.leftCols(kmax) * lambda.head(kmax).cwiseSqrt().asDiagonal();  // n x kmax
  out.samples = options.samples;
  std::mt19937_64 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::MatrixXd S(options.samples, kmax);
  for (int s = 0; s < options.samples; ++s)
    for (int l = 0; l < kmax; ++l) S(s, l) = normal(rng) * std::sqrt(lambda(l) / double(n - 1));
  for (int k : out.components) {
    Eigen::VectorXd residual = G.diagonal();
    for (int l = 0; l < k; ++l) residual -= A.col(l).cwiseAbs2();
    residual = residual.cwiseMax(0.0);
    double sum = 0;
    for (int s = 0; s < options.samples; ++s) {
      const Eigen::VectorXd d2 = (A.leftCols(k).rowwise() - S.row(s).head(k)).rowwise().squaredNorm() + residual;
      sum += std::sqrt(d2.minCoeff() / double(V));
    }
    out.specificity_mm.push_back(sum / options.samples);
  }

  // Generalisation: leave each of (up to max_held_out) subjects out. With J the others (m of them), C = I - 11^T/m,
  // the model of J has eigenpairs (mu, W) of C G_JJ C; the left-out x_i - mean_J projects to p = W^T h / sqrt(mu) with
  // h = C (G_Ji - G_JJ 1/m), and the residual is a combination of the subjects with coefficients c (c_i = 1,
  // c_J = -1/m - C W diag(1/sqrt(mu)) p), so its squared norm over a region is c^T G_r c.
  std::vector<int> held;
  const int count = int(std::min<Eigen::Index>(n, options.max_held_out));
  for (int t = 0; t < count; ++t) held.push_back(int(int64_t(t) * n / count));
  out.held_out = count;
  std::vector<std::vector<double>> total(K, std::vector<double>(size_t(count))),
      by_region(K * size_t(regions), std::vector<double>(size_t(count)));
  parallel_for(0, count, [&](int64_t t0, int64_t t1) {
    for (int64_t t = t0; t < t1; ++t) {
      const int i = held[size_t(t)];
      const Eigen::Index m = n - 1;
      std::vector<Eigen::Index> J;
      for (Eigen::Index j = 0; j < n; ++j)
        if (j != i) J.push_back(j);
      Eigen::MatrixXd GJ(m, m);
      Eigen::VectorXd gi(m);
      for (Eigen::Index a = 0; a < m; ++a) {
        gi(a) = G(J[size_t(a)], i);
        for (Eigen::Index b = 0; b < m; ++b) GJ(a, b) = G(J[size_t(a)], J[size_t(b)]);
      }
      const auto centre = [&](const Eigen::MatrixXd& M) { return Eigen::MatrixXd(M.rowwise() - M.colwise().mean()); };
      const Eigen::MatrixXd CGC = centre(centre(GJ).transpose());
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(CGC);
      const Eigen::VectorXd mu = e.eigenvalues().reverse();
      const Eigen::MatrixXd W = e.eigenvectors().rowwise().reverse();
      Eigen::VectorXd h = gi - GJ.rowwise().mean();
      h.array() -= h.mean();
      Eigen::VectorXd v = Eigen::VectorXd::Zero(m);  // sum over l <= k of p_l w_l / sqrt(mu_l)
      int l = 0;
      for (size_t q = 0; q < K; ++q) {
        for (; l < out.components[q]; ++l) {
          if (mu(l) <= mu(0) * 1e-12) continue;
          v += (W.col(l).dot(h) / mu(l)) * W.col(l);
        }
        Eigen::VectorXd cJ = -(v.array() - v.mean()).matrix();
        cJ.array() -= 1.0 / double(m);
        Eigen::VectorXd c(n);
        c(i) = 1;
        for (Eigen::Index a = 0; a < m; ++a) c(J[size_t(a)]) = cJ(a);
        double sum = 0;
        for (int r = 0; r < regions; ++r) {
          const double e2 = std::max(0.0, c.dot(Gr[size_t(r)] * c));
          sum += e2;
          by_region[q * size_t(regions) + size_t(r)][size_t(t)] =
              region_vertices[size_t(r)] > 0 ? std::sqrt(e2 / region_vertices[size_t(r)]) : 0.0;
        }
        total[q][size_t(t)] = std::sqrt(sum / double(V));
      }
    }
  }, 1);
  const auto mean_of = [](const std::vector<double>& x) {
    double s = 0;
    for (double v : x) s += v;
    return x.empty() ? 0.0 : s / double(x.size());
  };
  out.generalization_region_mm.assign(size_t(regions), std::vector<double>(K));
  for (size_t q = 0; q < K; ++q) {
    out.generalization_mm.push_back(mean_of(total[q]));
    for (int r = 0; r < regions; ++r) out.generalization_region_mm[size_t(r)][q] = mean_of(by_region[q * size_t(regions) + size_t(r)]);
  }
  return out;
}

ModelMetrics evaluate_model(EvaluateModelOptions opt) {
  namespace fs = std::filesystem;
  opt.check();
  const MorphableModel model = read_model(opt.model);
  if (opt.output.empty()) opt.output = (fs::path(opt.model).parent_path() / fs::path(opt.model).stem()).string() + "_metrics";
  std::vector<std::string> dirs;
  for (const std::string& s : model.subjects) {
    const std::string d = opt.registered + "/" + s;
    if (!fs::is_directory(d)) {
      throw InvalidInput(d, "is missing: the model was trained on subject " + s,
                         "give the registered folder the model was built from");
    }
    dirs.push_back(d);
  }
  TemplateFace face;
  face.mesh = model.topology;
  face.landmark_vertices = model.landmark_vertices;
  RowMatrixXf X = read_shapes(face, dirs);
  // Into the model frame with the model's own Procrustes transforms.
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const Eigen::Matrix4d& T = model.procrustes.at(size_t(i));
    Eigen::Map<Eigen::Matrix<float, 3, Eigen::Dynamic>> P(X.row(i).data(), 3, X.cols() / 3);
    P = ((T.topLeftCorner<3, 3>() * P.cast<double>()).colwise() + T.topRightCorner<3, 1>()).cast<float>();
  }
  const auto t0 = std::chrono::steady_clock::now();
  const ModelMetrics m = model_metrics(X, model.vertex_region, model.region_names, opt.metrics);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  AtomicDirectory out(opt.output);
  std::string csv = "components,compactness,generalization_mm,specificity_mm";
  for (const std::string& r : m.regions) csv += ",generalization_" + r + "_mm";
  csv += "\n";
  for (size_t q = 0; q < m.components.size(); ++q) {
    csv += fmt::format("{},{:.6f},{:.5f},{:.5f}", m.components[q], m.compactness[q], m.generalization_mm[q],
                       m.specificity_mm[q]);
    for (const auto& r : m.generalization_region_mm) csv += fmt::format(",{:.5f}", r[q]);
    csv += "\n";
  }
  write_file_atomic(out.path() + "/metrics.csv", csv);
  nlohmann::json j = {{"model", opt.model},
                      {"subjects", m.subjects},
                      {"held_out", m.held_out},
                      {"samples", m.samples},
                      {"distance", "RMS over vertices of the per-vertex Euclidean distance, mm, in the model frame"},
                      {"components", m.components},
                      {"compactness", m.compactness},
                      {"generalization_mm", m.generalization_mm},
                      {"specificity_mm", m.specificity_mm},
                      {"seconds", seconds}};
  for (size_t r = 0; r < m.regions.size(); ++r) j["generalization_region_mm"][m.regions[r]] = m.generalization_region_mm[r];
  write_file_atomic(out.path() + "/metrics.json", j.dump(1) + "\n");
  std::vector<double> k(m.components.begin(), m.components.end());
  const auto chart = [&](const std::string& name, const std::string& title, const std::string& y,
                         std::vector<ChartSeries> series) {
    write_file_atomic(out.path() + "/" + name + ".svg", svg_line_chart({title, "components", y, std::move(series)}));
  };
  chart("compactness", "Compactness", "explained variance fraction", {{"shape", k, m.compactness}});
  chart("generalization", "Generalisation (leave-one-out)", "RMS vertex error, mm", {{"all vertices", k, m.generalization_mm}});
  chart("specificity", "Specificity", "RMS distance to nearest training shape, mm", {{"shape", k, m.specificity_mm}});
  std::vector<ChartSeries> regions;
  for (size_t r = 0; r < m.regions.size(); ++r) regions.push_back({m.regions[r], k, m.generalization_region_mm[r]});
  chart("generalization_regions", "Generalisation per region", "RMS vertex error, mm", regions);
  if (!opt.config.empty()) write_file_atomic(out.path() + "/config.json", opt.config);
  out.commit();
  spdlog::info("mm-eval: {} subjects; at {} components: compactness {:.3f}, generalisation {:.3f} mm, specificity "
               "{:.3f} mm ({:.1f} s) -> {}",
               m.subjects, m.components.back(), m.compactness.back(), m.generalization_mm.back(),
               m.specificity_mm.back(), seconds, opt.output);
  return m;
}

}  // namespace bareskin
