// bareskin recon --eval (apps/recon_eval.cc): a trained F/E on held-out face samples against their truth and against
// mm-fit's landmark fitter on the same faces.
#pragma once
#include <string>
#include <vector>

#include "apps/cli.h"
#include "training/recon.h"

namespace bareskin::cli {

struct EvalOptions {
  std::string data, run, model, output, input = "before";
  int64_t max_faces = 0;  // 0: every sample of the split
  int64_t heat_maps = 4;  // photo | overlay | error strips for the first faces
  std::vector<int> fit_iterations = {1, 2, 3, 5, 10, 20, 40};
  double bad_mm = 3.0;  // the shape error the confidence should flag
  bool identity = true;  // identity cosine through face-api's recognition net
  recon::ConfidenceOptions confidence;
};

void evaluate_recon(const EvalOptions& options, const Globals& globals);

}  // namespace bareskin::cli
