// Building the morphable model (`mm-build`) from registered subjects (registered/<id>/{mesh.ply, diffuse.*}):
// generalised Procrustes → identity shape PCA (α) · appearance PCA of the diffuse map in UV (δ, linear RGB, masked to
// the UV layout) · expression basis (β) from a blendshape set moved onto the mean identity and orthonormalised (SVD).
#pragma once
#include <string>
#include <vector>

#include "core/progress.h"
#include "morphable/model.h"
#include "template/template_face.h"

namespace bareskin {

struct BuildOptions {
  int shape_components = 120;       // at most n - 1 ...
  double shape_variance = 0;        // ... or fewer, when > 0: as many as explain this fraction
  int appearance_components = 52;
  int appearance_resolution = 256;  // R: the diffuse maps are box-filtered in linear light down to R x R
  int expression_components = 120;  // at most the number of blendshapes
  bool procrustes_scale = false;    // GPA with scale (a similarity) instead of rigid
  // Counts given explicitly: asking for more than the data gives is InvalidInput (otherwise clamped, with a note).
  struct {
    bool shape = false, appearance = false, expression = false;
  } exact;
  void check() const;
};

struct NamedShape {
  std::string name;
  Eigen::MatrixX3d delta;  // #V x 3, mm, on the template
};

struct BuildReport {
  int subjects = 0;
  int gpa_iterations = 0;
  double shape_variance_explained = 0, appearance_variance_explained = 0;
  double seconds_read_shapes = 0, seconds_gpa = 0, seconds_shape_pca = 0, seconds_read_maps = 0,
         seconds_appearance_pca = 0, seconds_expression = 0;
  int appearance_subjects = 0;                        // subjects with a diffuse map (the appearance PCA's)
  std::vector<std::string> subjects_without_diffuse;  // left out of the appearance model
  std::vector<std::string> notes;  // clamped component counts and the like
};

// Face regions per template vertex (for per-region metrics), from the nearest iBUG-68 landmark group: forehead,
// brows, eyes, nose, mouth, cheeks and jaw.
std::vector<uint8_t> face_regions(const TemplateFace& face, std::vector<std::string>& names);

// 1 for texels of an R x R UV image (row 0 at the top) whose centre lies in a UV triangle of `mesh`.
std::vector<uint8_t> uv_mask(const Mesh& mesh, int resolution);

// The subjects' folders → the model. The folders hold mesh.ply (or .obj) with the template's topology and, for the
// appearance model, a diffuse map in the template UV (square, a multiple of R); subjects without one are left out of
// the appearance model and listed in the report. InvalidInput naming the file on a wrong vertex count or triangle
// list, NaN, a mis-sized map, fewer than 3 subjects, no variance.
MorphableModel build_model(const TemplateFace& face, const std::vector<std::string>& subject_dirs,
                           const std::vector<NamedShape>& blendshapes, const BuildOptions& options, BuildReport& report,
                           const ProgressCallback& progress = {});

// Reads the subjects' registered meshes into a data matrix (one row per subject), checking them against the template.
RowMatrixXf read_shapes(const TemplateFace& face, const std::vector<std::string>& subject_dirs,
                        const ProgressCallback& progress = {});

}  // namespace bareskin
