// `bareskin recon --eval`: a trained F/E on held-out face samples against their truth and against mm-fit's landmark
// fitter on the same faces. Joins the geometry side (mm-fit, image files), so it is its own library, built where the
// geometry modules are (not on the Torch-only GPU build).
#pragma once
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/progress.h"
#include "recon/recon.h"

namespace bareskin::recon {

struct EvalOptions {
  std::string data, run, output, input = "before";
  std::string model;  // "": the one the run was trained with
  int64_t max_faces = 0;  // 0: every sample of the split
  int64_t heat_maps = 4;  // photo | overlay | error strips for the first faces
  std::vector<int> fit_iterations = {1, 2, 3, 5, 10, 20, 40};
  double bad_mm = 3.0;  // the shape error the confidence should flag
  bool identity = true;  // identity cosine through face-api's recognition net
  ConfidenceOptions confidence;
  void check() const;  // InvalidInput naming the flag
};

// Writes metrics.json, faces.csv, speed.csv, SVG charts and heat-map strips into options.output and returns the
// summary (metrics.json's content).
nlohmann::json evaluate_recon(const EvalOptions& options, const ProgressCallback& progress = {});

}  // namespace bareskin::recon
