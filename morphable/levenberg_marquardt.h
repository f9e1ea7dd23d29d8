// Levenberg–Marquardt over a dense residual vector with forward-difference Jacobians: the landmark fits' solver
// (morphable/fit.cc's single view, fitting/multiview_fit.cc's joint fit of several views).
#pragma once
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>

namespace bareskin {

// Minimises |residuals(x)|² from `x`; `r` holds residuals(x) on entry and on return. `difference_step(p)` is the
// forward-difference step of parameter p. λ starts at 1e-3 (scaled by diag JᵀJ), is cut 3× after an accepted step and
// raised 10× after a rejected one (at most 10 tries per iteration). Stops after `iterations`, when no step improves,
// or when the cost falls by less than 1e-10 relative. `after_iteration(it)` runs after each iteration (1-based).
// Returns the number of iterations run.
template <class Residuals, class DifferenceStep, class AfterIteration>
int levenberg_marquardt(Eigen::VectorXd& x, Eigen::VectorXd& r, const Residuals& residuals,
                        const DifferenceStep& difference_step, int iterations, const AfterIteration& after_iteration) {
  const Eigen::Index M = r.size(), P = x.size();
  double cost = r.squaredNorm(), lambda = 1e-3;
  bool converged = false;
  int run = 0;
  for (int it = 0; it < iterations && !converged; ++it) {
    Eigen::MatrixXd J(M, P);
    for (Eigen::Index p = 0; p < P; ++p) {
      const double h = difference_step(p);
      Eigen::VectorXd xp = x;
      xp(p) += h;
      J.col(p) = (residuals(xp) - r) / h;
    }
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      Eigen::MatrixXd A = JtJ;
      A.diagonal() += lambda * JtJ.diagonal().cwiseMax(1e-9);
      const Eigen::VectorXd step = A.ldlt().solve(-g);
      const Eigen::VectorXd r_new = residuals(x + step);
      if (r_new.squaredNorm() < cost) {
        x += step;
        r = r_new;
        const double previous = cost;
        cost = r.squaredNorm();
        lambda = std::max(lambda / 3, 1e-9);
        improved = true;
        converged = previous - cost < 1e-10 * previous;
      } else {
        lambda *= 10;
      }
    }
    run = it + 1;
    after_iteration(run);
    if (!improved) break;
  }
  return run;
}

}  // namespace bareskin
