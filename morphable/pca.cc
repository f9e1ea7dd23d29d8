#include "morphable/pca.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <string>

#include "core/error.h"
#include "core/parallel.h"

namespace bareskin {
namespace {
constexpr Eigen::Index kBlock = 2048;  // columns per block: n x 2048 doubles stay in cache-friendly sizes
}

Eigen::MatrixXd centred_gram(const RowMatrixXf& X, Eigen::VectorXd* mean_out) {
  const Eigen::Index n = X.rows(), D = X.cols();
  Eigen::VectorXd mean(D);
  const Eigen::Index blocks = (D + kBlock - 1) / kBlock;
  // One partial Gram per worker chunk, summed in a fixed order, so results do not depend on scheduling.
  const int64_t parts = std::min<int64_t>(blocks, 64);
  std::vector<Eigen::MatrixXd> partial(static_cast<size_t>(parts), Eigen::MatrixXd::Zero(n, n));
  parallel_for(0, parts, [&](int64_t p0, int64_t p1) {
    for (int64_t p = p0; p < p1; ++p) {
      for (Eigen::Index b = p * blocks / parts; b < (p + 1) * blocks / parts; ++b) {
        const Eigen::Index c0 = b * kBlock, w = std::min(kBlock, D - c0);
        Eigen::MatrixXd B = X.middleCols(c0, w).cast<double>();
        const Eigen::RowVectorXd mu = B.colwise().mean();
        mean.segment(c0, w) = mu.transpose();
        B.rowwise() -= mu;
        partial[size_t(p)].selfadjointView<Eigen::Lower>().rankUpdate(B);
      }
    }
  }, 1);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, n);
  for (const Eigen::MatrixXd& P : partial) G += P;
  G = G.selfadjointView<Eigen::Lower>();
  if (mean_out) *mean_out = mean;
  return G;
}

Pca pca(const RowMatrixXf& X, int components, double variance_fraction, const char* what) {
  const Eigen::Index n = X.rows(), D = X.cols();
  if (n < 2) throw InvalidInput("", std::string(what) + ": a model needs at least 2 subjects, got " + std::to_string(n), "");
  if (components < 1 || components > n - 1) {
    throw InvalidInput("", std::string(what) + ": " + std::to_string(components) + " components asked, " +
                               std::to_string(n) + " subjects give at most " + std::to_string(n - 1),
                       "ask for fewer components or add subjects");
  }
  Pca out;
  const Eigen::MatrixXd G = centred_gram(X, &out.mean);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(G);
  if (eig.info() != Eigen::Success) throw InternalError(std::string(what) + ": Gram eigendecomposition failed");
  out.gram_eigenvalues = eig.eigenvalues().reverse().cwiseMax(0.0);
  out.gram_eigenvectors = eig.eigenvectors().rowwise().reverse();
  out.total_variance = G.trace() / double(n - 1);
  if (!(out.gram_eigenvalues(0) > 0) || !(out.total_variance > 1e-20)) {
    throw InvalidInput("", std::string(what) + ": every subject is the same (no variance)", "give distinct subjects");
  }
  // Components with no variance cannot be normalised: the data spans fewer dimensions than asked.
  const double floor = out.gram_eigenvalues(0) * 1e-12;
  if (out.gram_eigenvalues(components - 1) <= floor) {
    int rank = 0;
    while (rank < n && out.gram_eigenvalues(rank) > floor) ++rank;
    throw InvalidInput("", std::string(what) + ": the data spans " + std::to_string(rank) + " dimensions, " +
                               std::to_string(components) + " components asked",
                       "ask for at most " + std::to_string(rank) + " components");
  }
  if (variance_fraction > 0) components = std::min(components, components_for_variance(out, variance_fraction));
  out.variance = out.gram_eigenvalues.head(components) / double(n - 1);
  // basis = diag(1/sqrt(lambda)) U^T X_c, in column blocks.
  const Eigen::MatrixXd W =
      (out.gram_eigenvectors.leftCols(components) * out.gram_eigenvalues.head(components).cwiseSqrt().cwiseInverse().asDiagonal())
          .transpose();
  out.basis.resize(components, D);
  const Eigen::Index blocks = (D + kBlock - 1) / kBlock;
  parallel_for(0, blocks, [&](int64_t b0, int64_t b1) {
    for (int64_t b = b0; b < b1; ++b) {
      const Eigen::Index c0 = b * kBlock, w = std::min(kBlock, D - c0);
      Eigen::MatrixXd B = X.middleCols(c0, w).cast<double>();
      B.rowwise() -= out.mean.segment(c0, w).transpose();
      out.basis.middleCols(c0, w).noalias() = W * B;
    }
  }, 1);
  return out;
}

int components_for_variance(const Pca& p, double fraction) {
  const double total = p.gram_eigenvalues.sum();
  double sum = 0;
  for (Eigen::Index k = 0; k < p.gram_eigenvalues.size(); ++k) {
    sum += p.gram_eigenvalues(k);
    if (sum >= fraction * total) return int(k + 1);
  }
  return int(p.gram_eigenvalues.size());
}

}  // namespace bareskin
