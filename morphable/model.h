// The 3D morphable model (frame: docs/pipeline.md): shape S = S̄ + B_id α + B_exp β on the template topology (mm) and diffuse
// appearance A = Ā + B_a δ in the template UV (linear RGB). Bases are stored orthonormal with their standard deviations
// beside them; coefficients are standardised (α, β, δ ~ N(0, 1) over the training population), so
// S = S̄ + U_id diag(σ_id) α, and likewise for β and δ. Eigen only: the Torch side reads the same file.
//
// File (safetensors, docs/file_formats.md): shape_mean [V,3], shape_basis [K_id,V,3], shape_stddev [K_id],
// expression_basis [K_exp,V,3], expression_stddev [K_exp], appearance_mean [R,R,3], appearance_basis [K_a,R,R,3],
// appearance_stddev [K_a], appearance_mask [R,R] (U8), triangles [F,3], uvs [T,2], uv_triangles [F,3],
// landmark_vertices [68], vertex_region [V] (U8, names in metadata), procrustes [N,4,4] (subject → model frame).
#pragma once
#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace bareskin {

using RowMatrixXf = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct MorphableModel {
  Mesh topology;                       // V = the mean shape; F, UV, FUV
  std::vector<int> landmark_vertices;  // 68, iBUG order
  std::vector<uint8_t> vertex_region;  // per vertex, index into region_names
  std::vector<std::string> region_names;

  // Each basis: one component per row (K x 3V or K x 3R^2), orthonormal rows, float64 maths stored float32.
  RowMatrixXf shape_basis, expression_basis, appearance_basis;
  Eigen::VectorXf shape_stddev, expression_stddev, appearance_stddev;
  std::vector<std::string> expression_names;  // the blendshapes the expression basis came from

  int appearance_resolution = 0;     // R
  Eigen::VectorXf appearance_mean;   // R*R*3, row-major image (row 0 at the top, v = 1), linear RGB
  std::vector<uint8_t> appearance_mask;  // R*R: 1 where the texel is inside a UV triangle (modelled)

  std::vector<std::string> subjects;          // training subjects, in order
  std::vector<Eigen::Matrix4d> procrustes;    // per subject: its registered mesh → the model frame
  std::map<std::string, std::string> metadata;  // provenance, config, ... (format keys are added on write)

  int vertices() const { return int(topology.V.rows()); }
  // S̄ + U_id diag(σ_id) α + U_exp diag(σ_exp) β; missing trailing coefficients are 0. InvalidInput when too many or
  // not finite.
  Eigen::MatrixX3d shape(const Eigen::VectorXd& alpha, const Eigen::VectorXd& beta = {}) const;
  // Ā + U_a diag(σ_a) δ as an R x R linear RGB image (float, row-major RGB).
  std::vector<float> appearance(const Eigen::VectorXd& delta) const;
};

// Throws IoError / InvalidInput naming the file (missing tensors, shapes that do not agree, NaN).
MorphableModel read_model(const std::string& path);
void write_model(const std::string& path, const MorphableModel& model);  // atomic

// `render --blendshapes --expression NAME=WEIGHT,...`: `mesh` posed by the weighted deltas of a blendshape file
// (safetensors "deltas" [K, V, 3], metadata "names"; `scan synth` writes it), its normals dropped. Nothing without a
// file; InvalidInput for an expression without one, an unknown name or a weight that is not a number.
void pose_blendshapes(Mesh& mesh, const std::string& blendshapes, const std::vector<std::string>& expression);

}  // namespace bareskin
