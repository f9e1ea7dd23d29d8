// The model prior of `scan register --model` (docs/pipeline.md, registration): the bootstrapping scheme of large-scale
// face models (e.g. LSFM: register with NICP, build a 3DMM, re-register with the model as prior). After the landmark
// similarity, the model's identity shape S(α) = S̄ + U diag(σ) α is fitted to the scan by a few ICP rounds: closest
// points on the scan, point-to-plane residuals n·(s R S_i(α) + t − c_i), solved as a regularised linear least squares
// in α together with a linearised step of the similarity (s, R, t); the landmarks pull only weakly, each
// weighted by its σ when known. NICP then starts from the fitted shape: the model already puts each vertex where the
// population's registrations have it, so NICP only has to take up what the model cannot express.
#pragma once
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "morphable/model.h"

namespace bareskin {

struct ModelPriorOptions {
  int iterations = 6;             // ICP rounds of the model fit
  int components = 0;             // identity components fitted (0: all the model has)
  // λ in mm²: the prior |α|² against the mean squared point-to-plane residual over the accepted vertices (a unit
  // coefficient costs as much as a λ^½ mm RMS residual).
  double regularisation = 0.01;
  // The landmark term against the surface term: the weight of the mean squared landmark residual (mm²), each landmark
  // scaled by (median σ / σ_k)² (at most 1) when σ is known.
  double landmark_weight = 0.05;
  std::vector<double> trim_mm = {10, 5, 3, 3, 2, 2};  // correspondence trim per round (the last repeats)
  // The ICP rounds find closest points for about this many well-spread vertices (spread_vertices), not all: 29 + 7
  // unknowns need far fewer rows, and the closest points are the fit's cost (0: every vertex).
  int vertices = 16000;
  // NICP after the fit: its landmark weights multiplied by this. 1 (unchanged) measured best on held-out scans
  // (bench/BENCHMARKS.md, "Model prior"): where the fit is wrong the landmarks still hold NICP; < 1 trusts the model more.
  double nicp_landmark_scale = 1;
  void check() const;  // InvalidInput when out of range
};

// Closest points on the scan for the vertices `rows` of V (mm, the scan's frame; V whole, so that its normals can be
// computed): per row, the point, the scan's unit normal there, and a weight (0: rejected: too far, on the scan's
// boundary, normals disagree).
struct ScanTargets {
  Eigen::MatrixX3d point, normal;
  Eigen::VectorXd weight;
};
using ScanTargetQuery =
    std::function<ScanTargets(const Eigen::MatrixX3d& V, const std::vector<int>& rows, double trim_mm)>;

// About `count` vertices of V spread evenly over its surface (Poisson-disk: in index order, a vertex is kept when no
// kept vertex lies within the spacing an even sampling of the surface area would have); all of them when count is 0
// or not smaller than V's rows. Sorted, deterministic.
std::vector<int> spread_vertices(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int count);

struct ModelPriorFit {
  Eigen::MatrixX3d V;            // the fitted shape on the scan (template topology, mm, scan frame)
  Eigen::VectorXd alpha;         // identity coefficients (standard deviations)
  Eigen::Matrix4d similarity;    // model frame -> scan frame
  std::vector<double> rms_mm;    // point-to-plane RMS over the accepted vertices, per round
  double landmark_rms_mm = 0;    // over the landmarks used, after the fit
  int vertices_used = 0;         // vertices whose closest points the rounds used
};

// `start`: the template aligned on the scan (same topology as the model), which places the model (Umeyama over every
// vertex). `landmarks`: 68 x 3 (mm) or null; `landmark_ids` the ones used; `landmark_sigma_mm` 68 values or empty.
ModelPriorFit fit_model_to_scan(const MorphableModel& model, const Eigen::MatrixX3d& start, const ScanTargetQuery& query,
                                const Eigen::MatrixX3d* landmarks, const std::vector<int>& landmark_ids,
                                const std::vector<double>& landmark_sigma_mm, const ModelPriorOptions& options);

// The model must be built on this template (same vertices, triangles and landmark vertices): InvalidInput naming
// `model_path` otherwise.
void check_model_template(const MorphableModel& model, const Mesh& template_mesh, const std::vector<int>& landmark_vertices,
                          const std::string& model_path);

// Per landmark: (median σ / σ_k)², at most 1 (σ_k <= 0 or unknown: 1). Empty when `sigma_mm` is empty.
std::vector<double> landmark_sigma_weights(const std::vector<double>& sigma_mm);

}  // namespace bareskin
