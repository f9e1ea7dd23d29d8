// Principal component analysis of a population (rows = subjects), in float64 from float32 data, by the Gram matrix:
// with n subjects of D numbers each and n << D (180 x 195k), the n x n matrix G = X_c X_c^T is formed in column blocks
// and decomposed, and the components are X_c^T u / sqrt(lambda). This is cheaper than an SVD of X_c and than Lanczos
// on the D x D covariance (bench/mm_pca.sh measures it against numpy). The data matrix is the only copy of the data.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "morphable/model.h"

namespace bareskin {

struct Pca {
  Eigen::VectorXd mean;       // D
  Eigen::MatrixXd basis;      // K x D, orthonormal rows, by decreasing variance
  Eigen::VectorXd variance;   // K, per component (divided by n - 1)
  double total_variance = 0;  // trace of the covariance
  // Of the Gram matrix of the centred data (n x n), for the metrics: all eigenvalues (descending) and vectors.
  Eigen::VectorXd gram_eigenvalues;
  Eigen::MatrixXd gram_eigenvectors;
};

// Centred Gram matrix of the rows of X (n x n, float64). Columns are processed in blocks on all threads.
Eigen::MatrixXd centred_gram(const RowMatrixXf& X, Eigen::VectorXd* mean = nullptr);

// The first `components` principal components (at most n - 1), or fewer when `variance_fraction` > 0 and fewer
// explain that fraction of the variance. InvalidInput when n < 2, when `components` exceeds n - 1 or the data's rank,
// or when the data has no variance. `what` names the data in errors ("shape", "appearance").
Pca pca(const RowMatrixXf& X, int components, double variance_fraction, const char* what);

// Smallest K whose components explain `fraction` of the variance (from the Gram eigenvalues).
int components_for_variance(const Pca& p, double fraction);

}  // namespace bareskin
