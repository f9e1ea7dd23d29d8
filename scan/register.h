// `scan register`: brings the template onto a scan (docs/pipeline.md, registration). A similarity from the 68 landmarks (Umeyama), then
// optimal-step non-rigid ICP (Amberg, Romdhani & Vetter 2007): one affine transform per template vertex, a stiffness
// term on neighbouring transforms that is relaxed step by step (neighbours must agree at the nodes, as in embedded
// deformation, plus a little of Amberg's affine difference), a landmark term whose weight decays, and a data
// term to the closest points of the scan (projections onto its triangles, found in a CGAL AABB tree). Correspondences
// are rejected when the normals disagree, when the closest point lies on the scan's boundary (holes, the scan's rim),
// or beyond a distance trimmed with the schedule; the rest get Huber weights (robust loss). Each step solves the
// sparse normal equations with CHOLMOD (supernodal Cholesky), whose symbolic analysis is done once: the pattern never
// changes. The transforms live on a coarser node mesh (the template remeshed, ~2k vertices) and the dense template
// follows by blending them; a final projection puts each accepted vertex on the scan.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/landmarks.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "morphable/model.h"
#include "scan/model_prior.h"
#include "scan/texture_landmarks.h"
#include "scan/texture_refine.h"
#include "template/template_face.h"

namespace bareskin {

struct RegisterOptions {
  // Stiffness schedule (alpha, relaxed step by step; the soft last steps hold the p95 and let sparse landmarks place
  // the face: bench/BENCHMARKS.md) and the landmark weight at each step (beta, decaying to 0).
  std::vector<double> stiffness = {4, 2, 1, 0.4, 0.05, 0.01};
  std::vector<double> landmark_weight = {90, 60, 30, 15, 6, 3};
  // The landmarks used (iBUG indices; empty: all 68). Detected landmarks leave out the jaw contour (0-16), which a
  // 2D detector puts on the silhouette rather than on fixed points of the surface.
  std::vector<int> landmark_ids;
  int iterations_per_step = 3;       // inner ICP iterations at one stiffness (stops early when converged)
  double consistency = 1;            // stiffness: weight of neighbouring affines agreeing at the nodes
  double affine_stiffness = 0.03;    // stiffness: weight of Amberg's affine difference (consistency 0, this 1: Amberg)
  double gamma = 1;                  // weight of its translation part (Amberg's G = diag(1,1,1,gamma))
  double max_normal_angle_deg = 60;  // reject a correspondence whose normals differ more
  std::vector<double> trim_mm = {20, 10, 5, 3, 2, 2};  // reject beyond this distance, per step
  double huber_mm = 1.0;             // robust loss: weight min(1, huber / distance)
  // Tangential-displacement prior, per step (empty or zeros: off): each node's displacement from a reference is
  // penalised in the reference's tangent plane with this weight (against the closest-point term's <= 1), so that shape
  // differences are explained along the normals rather than by sliding points over a bump. The reference is NICP's
  // start under the similarity that best explains the current fit as displacements along the start's normals (refitted
  // every iteration): the scan's placement and scale, none of its shape. A prior: shape differences lie mostly along
  // the normal (its effect: bench/BENCHMARKS.md, registration).
  std::vector<double> tangential_weight = {0.1, 0.1, 0.1, 0.1, 0.1, 0.1};
  // Outline term (0: off): for scans cut along the template's face outline (forehead, temples, jaw line), as `scan
  // synth` makes them or a face mask crops them. Every NICP iteration draws each template outline vertex (its longest
  // border loop) to the closest point of the scan's longest border loop with this weight (against the closest-point
  // term's <= 1 per node). Where a scan goes on past the outline (neck, ears) it is wrong: leave it off.
  double outline_weight = 0;
  bool project = true;               // finally move accepted vertices onto their closest scan point
  // NICP nodes: the template is remeshed to about this many vertices for the optimisation and every template vertex
  // follows the blend of its node triangle's affines (0: one affine per template vertex, slow at 65k).
  int nodes = kDefaultNodes;  // 2000: the template folder keeps this layout (template/node_layout.h)
  // Per landmark (68 values, or empty: unknown): the detector's uncertainty (mm). The model prior weights each landmark
  // by (median σ / σ_k)², and so does NICP's landmark term when sigma_weighted_nicp is set.
  std::vector<double> landmark_sigma_mm;
  bool sigma_weighted_nicp = false;
  // With a model (register_scan's `model`): its fit before NICP (model_prior.h).
  ModelPriorOptions prior;
  // After NICP: rounds of texture-aware refinement (texture_refine.h; needs the scan's diffuse and a reference).
  TextureRefineOptions texture;
  void check() const;                // InvalidInput when inconsistent
};

struct RegistrationStats {
  bool used_landmarks = false;
  int nodes = 0;  // NICP nodes used
  double similarity_scale = 1;
  double landmark_rms_after_similarity_mm = 0;
  int iterations = 0;
  double accepted_fraction = 0;  // of template vertices with an accepted correspondence at the end
  // Model prior: point-to-plane RMS per round, |α|, landmark RMS after the fit (used_model false: no model given).
  bool used_model = false;
  std::vector<double> model_rms_mm;
  double model_alpha_norm = 0, model_landmark_rms_mm = 0, seconds_model = 0;
  int model_vertices_used = 0;  // vertices whose closest points the model fit used
  double seconds_similarity = 0, seconds_nicp = 0, seconds_factorize = 0, seconds_correspond = 0;
  double seconds_nodes = 0, seconds_project = 0;  // inside seconds_nicp: the node embedding, the final projection
  // Texture refinement, per round: template vertices with a texture correspondence, their median move (mm).
  std::vector<int> texture_targets;
  std::vector<double> texture_median_flow_mm;
  double seconds_texture = 0;
  // Texture landmarks, per round: how many were found, their median move (mm).
  std::vector<int> texture_landmarks_found;
  std::vector<double> texture_landmarks_move_mm;
  std::vector<int> shape_points_found;  // and how many shape points
  double seconds_texture_landmarks = 0;
  // Outline term (outline_weight > 0): the template outline's median and largest distance to the scan's border (mm).
  double outline_median_mm = -1, outline_max_mm = -1;
};

struct Registration {
  Eigen::MatrixX3d V;  // template topology, on the scan (mm, the scan's frame)
  std::vector<bool> accepted;  // per template vertex: had an accepted correspondence at the end
  Eigen::MatrixX3d V_before_texture;  // V before the texture refinement (empty when it did not run)
  Eigen::MatrixX3d V_model;           // the model prior's fitted shape, NICP's start (empty without a model)
  TextureLandmarks texture_landmarks;  // the last round's (no ids when none ran)
  RegistrationStats stats;
};

// What the texture refinement reads: the scan's diffuse (linear, in the scan's atlas) and the reference diffuse in
// the template UV (linear or sRGB, any square size). Both null: no refinement.
struct RegistrationTexture {
  const Image* scan_diffuse = nullptr;
  const Image* reference = nullptr;
};

// Checks the scan's landmarks against the template's: millimetres (eye-corner distance), order and handedness
// (the similarity fit must be good). Throws InvalidInput naming `source` with what is wrong and what to do.
void check_scan_landmarks(const TemplateFace& face, const Landmarks& landmarks, const std::string& source);

// Registers the template to `scan`. Without landmarks (nullptr) the fallback is documented: the template is centred
// and scaled onto the scan's centroid and RMS radius, assuming the scan is in the template's orientation (+y up, +z
// out of the face), then ICP with a similarity (rotation, translation, scale); stats.used_landmarks says which ran.
// With both texture images, options.texture.landmark_rounds rounds of texture landmarks follow NICP (each: the
// brows, eyes and outer lip line found in the texture and the nose in the shape, then NICP again from the template
// placed by the similarity onto the last registration, with those points alone at the default landmark weights, the
// outer lip line's side points held across the line only, and no model; fewer than 10 found: the round is not
// used), and with options.texture.iterations > 0 the texture refinement runs last. options.outline_weight > 0 needs a scan with an
// open border (InvalidInput otherwise). With a `model` (built on this template:
// check_model_template), its shape is fitted after the similarity and NICP starts from it, with its landmark weights
// times options.prior.nicp_landmark_scale (default 1).
Registration register_scan(const TemplateFace& face, const Mesh& scan, const Landmarks* landmarks,
                           const RegisterOptions& options = {}, const ProgressCallback& progress = {},
                           const RegistrationTexture& texture = {}, const MorphableModel* model = nullptr);

// The texture refinement alone, from an existing registration V (template topology, on the scan): NICP is set up
// around V (its affines start at the identity, at the last stiffness) and options.texture.iterations rounds run.
Registration refine_with_texture(const TemplateFace& face, const Mesh& scan, const Eigen::MatrixX3d& V,
                                 const Landmarks* landmarks, const RegisterOptions& options,
                                 const RegistrationTexture& texture);

// Registration error, in mm. Surface distance: registered vertex to the scan surface. Correspondence error (when the
// scan has truth, e.g. from `scan synth`): registered vertex to its true point, over template vertices that are not in
// a hole (truth face >= 0). Landmark error: the template's 68 landmark vertices to the scan's landmarks.
struct RegistrationErrors {
  double distance_median = 0, distance_p95 = 0, distance_max = 0;
  bool has_truth = false;
  double correspondence_median = 0, correspondence_p95 = 0, correspondence_max = 0;
  bool has_landmarks = false;
  double landmark_mean = 0, landmark_max = 0;
  Eigen::VectorXd per_vertex;  // correspondence error with truth, else surface distance (for heat maps)
};
RegistrationErrors measure_registration(const TemplateFace& face, const Eigen::MatrixX3d& V, const Mesh& scan,
                                        const Landmarks* landmarks, const Eigen::MatrixX3d* truth_point,
                                        const Eigen::VectorXi* truth_face);

}  // namespace bareskin
