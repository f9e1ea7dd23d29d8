// Model metrics (as in scalismo-faces' ModelMetrics, Styner et al. 2003), for a shape PCA against its training data,
// as functions of the number of components K:
// - compactness: the fraction of the total variance the first K components explain;
// - generalisation: leave-one-out: each subject is left out, a model is built from the others and the subject is
//   reconstructed by projection onto its first K components; the error of the reconstruction;
// - specificity: random shapes of the K-component model (coefficients ~ N(0, sigma^2)), each to its nearest training
//   shape; the mean of those distances.
// Distances are the RMS over vertices of the per-vertex Euclidean distance (mm), in correspondence. Everything is
// computed in the n x n Gram matrices of the data (one per face region, summing to the whole), so leave-one-out costs
// O(n^3) per subject whatever the vertex count.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "morphable/model.h"

namespace bareskin {

struct MetricsOptions {
  int max_components = 120;
  int samples = 1000;       // specificity
  int max_held_out = 200;   // generalisation: at most this many subjects left out in turn (evenly spread)
  uint64_t seed = 1;
  void check() const;  // InvalidInput naming the flags
};

struct ModelMetrics {
  std::vector<int> components;           // the K evaluated
  std::vector<double> compactness;       // explained variance fraction at K
  std::vector<double> generalization_mm; // mean over held-out subjects
  std::vector<double> specificity_mm;    // mean over samples
  std::vector<std::string> regions;
  std::vector<std::vector<double>> generalization_region_mm;  // [region][K]
  int subjects = 0, held_out = 0, samples = 0;
};

// X: aligned shapes (one per row, x0 y0 z0 x1 ...). vertex_region: per vertex, index into region_names.
// InvalidInput with fewer than 4 subjects (leave-one-out needs a model of at least 2 from 3).
ModelMetrics model_metrics(const RowMatrixXf& X, const std::vector<uint8_t>& vertex_region,
                           const std::vector<std::string>& region_names, const MetricsOptions& options = {});

struct EvaluateModelOptions {
  std::string model;       // the model file (mm-build)
  std::string registered;  // its registered subjects, one folder per model subject
  std::string output;      // the report folder; "" = <model stem>_metrics beside the model
  std::string config;      // written as config.json into the report when not empty (the command's resolved flags)
  MetricsOptions metrics;
  void check() const;  // InvalidInput naming the flag
};

// `bareskin mm-eval`: the model's subjects read from `registered`, aligned into the model frame by its own Procrustes
// transforms, and their metrics written to the report folder (atomically): metrics.csv, metrics.json, compactness.svg,
// generalization.svg, specificity.svg, generalization_regions.svg. InvalidInput for a missing subject folder or a
// count option below 1.
ModelMetrics evaluate_model(EvaluateModelOptions options);

}  // namespace bareskin
