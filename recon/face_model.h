// The morphable model as a differentiable LibTorch layer (docs/training.md, "Face model"): coefficients [B, K] →
// shape S = S̄ + U_id diag(σ_id) α + U_exp diag(σ_exp) β → pose R S + t (R = Rz·Ry·Rx) → a pinhole camera (the
// canonical one: render/camera.h's view_camera("front", size, 0, 1000 mm)) → rasterize → albedo from the appearance
// image Ā + U_a diag(σ_a) δ in the template UV → SH shading with γ (render/torch/ops.h), the coverage mask and the 68
// projected landmarks. Gradients reach every coefficient through the vertex positions, normals, UVs and the texture
// (not through the silhouette: the covered pixels are held fixed). Batched; CPU tensors, or CUDA where the build has
// the CUDA rasterizer. Same file and same maths as morphable/ (geometry side), which is its test oracle.
//
// The coefficient vector (what the networks F and E regress, in the coefficient file's units):
//   [α (K_id) | β (K_exp) | δ (K_app) | rotation rx, ry, rz (rad) | translation tx, ty, tz (mm) | γ (27, optional)]
// with K_id, K_exp, K_app the model file's sizes. γ is absolute (Deep3DFaceRecon's +0.8 ambient included).
#pragma once
#include <torch/torch.h>

#include <nlohmann/json.hpp>
#include <string>

#include "render/camera.h"
#include "render/torch/ops.h"

namespace bareskin::recon {

// Sizes of the coefficient vector's groups.
struct CoefficientLayout {
  int64_t id = 0, exp = 0, app = 0;
  bool gamma = true;
  int64_t rotation_offset() const { return id + exp + app; }
  int64_t translation_offset() const { return rotation_offset() + 3; }
  int64_t gamma_offset() const { return translation_offset() + 3; }
  int64_t size() const { return gamma_offset() + (gamma ? 27 : 0); }
  bool operator==(const CoefficientLayout& o) const {
    return id == o.id && exp == o.exp && app == o.app && gamma == o.gamma;
  }
  std::string describe() const;  // "K_id 9, K_exp 48, K_app 9, gamma"
};

// The groups of a batch of coefficient vectors ([B, n] each). gamma is undefined where the layout has none.
struct FaceCoefficients {
  torch::Tensor alpha, beta, delta, rotation, translation, gamma;
};

// What one render gives, all [B, ...] in the input's dtype and device.
struct FaceRender {
  torch::Tensor colour;     // [B, 3, H, W] linear: albedo × SH irradiance (the albedo when no γ); 0 off the face
  torch::Tensor albedo;     // [B, 3, H, W] linear, unlit; 0 off the face
  torch::Tensor mask;       // [B, 1, H, W] 1 where the face mesh covers the pixel (no gradient)
  torch::Tensor landmarks;  // [B, 68, 2] pixels (origin at the image's top-left corner, pixel centres at +0.5)
  torch::Tensor vertices;   // [B, V, 3] posed vertices, mm (R S + t)
  torch::Tensor projected;  // [B, V, 3] pixel x, y and depth along the view axis
};

// R = Rz(rz)·Ry(ry)·Rx(rx) per row of angles [B, 3] → [B, 3, 3] (morphable/fit.h's euler_rotation).
torch::Tensor euler_rotation(const torch::Tensor& angles);

// The aligned-image camera: view_camera("front", size, origin, 1000 mm).
Camera canonical_camera(int size = 256);

class FaceModel {
 public:
  FaceModel() = default;
  // Reads a model file (morphable/model.h's format). IoError when it cannot be read; InvalidInput naming the file for
  // missing tensors, shapes that do not agree, or a model without 68 landmarks.
  static FaceModel load(const std::string& path);
  // The same model with its float tensors in `dtype` on `device`.
  FaceModel to(torch::Device device, torch::Dtype dtype = torch::kFloat) const;

  const CoefficientLayout& layout() const { return layout_; }
  // The layout without γ (the student E regresses no light).
  CoefficientLayout layout(bool gamma) const;
  int64_t vertices() const { return mean_.size(0); }
  int64_t appearance_resolution() const { return app_mean_.size(0); }
  const std::string& path() const { return path_; }
  const torch::Tensor& triangles() const { return triangles_; }           // [F, 3] int64
  const torch::Tensor& landmark_vertices() const { return landmarks_; }  // [68] int64
  const torch::Tensor& vertex_region() const { return region_; }         // [V] int64
  const std::vector<std::string>& region_names() const { return region_names_; }

  // [B, size] with or without the γ columns → groups (views of the input, so gradients flow). InvalidInput for
  // another width.
  FaceCoefficients split(const torch::Tensor& coefficients) const;
  torch::Tensor join(const FaceCoefficients& c) const;  // the inverse (γ columns where c.gamma is defined)

  torch::Tensor shape(const torch::Tensor& alpha, const torch::Tensor& beta) const;  // [B, V, 3] model frame, mm
  // shape(α, β) less the mean shape: [B, V, 3] mm (shape(α̂, β̂) − shape(α, β) = displacement(α̂ − α, β̂ − β)).
  torch::Tensor displacement(const torch::Tensor& alpha, const torch::Tensor& beta) const;
  torch::Tensor posed(const FaceCoefficients& c) const;                             // [B, V, 3]: R S + t
  torch::Tensor albedo_texture(const torch::Tensor& delta) const;                   // [B, 3, R, R], row 0 = v 1
  // Area-weighted unit vertex normals of [B, V, 3] vertices (core/mesh.h's vertex_normals).
  torch::Tensor normals(const torch::Tensor& vertices) const;
  // Pixel x, y (row 0 at the top) and depth of world points [B, N, 3] (render/camera.h's Camera::project).
  static torch::Tensor project(const torch::Tensor& points, const Camera& camera);

  // The whole layer. `coefficients` [B, layout().size()] or [B, layout(false).size()] (then unlit unless `gamma`
  // [B, 27] is given, e.g. the teacher's light for the student's geometry).
  FaceRender render(const torch::Tensor& coefficients, const Camera& camera,
                    const torch::Tensor& gamma = torch::Tensor()) const;
  FaceRender render(const FaceCoefficients& c, const Camera& camera) const;
  // The 68 landmarks alone (no rasterization): [B, 68, 2] pixels.
  torch::Tensor landmarks(const FaceCoefficients& c, const Camera& camera) const;

 private:
  std::string path_;
  CoefficientLayout layout_;
  torch::Tensor mean_;                                // [V, 3]
  torch::Tensor id_basis_, exp_basis_, app_basis_;   // [K, 3V] / [K, 3R²], scaled by σ
  torch::Tensor app_mean_;                            // [R, R, 3]
  torch::Tensor triangles_, landmarks_, region_;      // int64
  std::vector<std::string> region_names_;
  // Rendering topology: a vertex per distinct (vertex, uv) corner pair, so UV seams keep their own UVs.
  torch::Tensor render_vertex_;     // [Vr] int64: the model vertex of each render vertex
  torch::Tensor render_uv_;         // [Vr, 2]
  torch::Tensor render_triangles_;  // [F, 3] int64
};

// Coefficient file JSON (morphable/coefficients.h) ↔ one row of the coefficient vector. Reading pads missing
// trailing α/β/δ with 0 and takes γ when the layout has it (absent: Deep3DFaceRecon's ambient 0.8 per channel);
// InvalidInput (naming `source`) for longer lists than the model has or non-finite values.
torch::Tensor coefficients_from_json(const nlohmann::json& j, const CoefficientLayout& layout,
                                     const std::string& source = "");
nlohmann::json coefficients_to_json(const torch::Tensor& row, const CoefficientLayout& layout);

// A small synthetic model file in the model format (a face-like cap 150 × 190 mm with a nose on a grid, iBUG-68
// landmark vertices at face-like places, smooth random orthonormal bases, a patterned albedo, a UV seam down the
// middle): the fixture of Torch-side tests and benchmarks, which need no scans and no mm-build.
struct ToyModelOptions {
  int grid = 48;  // cells a side: (grid + 1)² vertices
  int id = 6, exp = 4, app = 3;
  int resolution = 64;  // appearance image
  uint64_t seed = 1;
  void check() const;   // InvalidInput when out of range
};
void save_toy_model(const std::string& path, const ToyModelOptions& options = {});

// Deep3DFaceRecon's ambient light as γ: 0.8 on the first coefficient of each channel, [27].
torch::Tensor ambient_gamma(torch::TensorOptions options = torch::TensorOptions().dtype(torch::kFloat));

}  // namespace bareskin::recon
