// Generalised Procrustes analysis of registered shapes (rows of a data matrix, x0 y0 z0 x1 ...): every shape is
// aligned to the running mean by a rigid motion (and a scale when asked), the mean is re-estimated and brought back
// onto the reference (the template) so the model keeps the template's frame, until the mean stops moving.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "morphable/model.h"

namespace bareskin {

struct GpaOptions {
  bool scale = false;         // similarity instead of rigid
  int max_iterations = 20;
  double tolerance_mm = 1e-4;  // RMS change of the mean between iterations
  void check() const;          // InvalidInput when out of range
};

struct GpaResult {
  std::vector<Eigen::Matrix4d> transforms;  // per row: original → aligned
  int iterations = 0;
  double mean_change_mm = 0;  // at the last iteration
};

// Aligns the rows of X in place. `reference` (#V x 3) fixes the frame.
GpaResult generalized_procrustes(RowMatrixXf& X, const Eigen::MatrixX3d& reference, const GpaOptions& options = {});

}  // namespace bareskin
