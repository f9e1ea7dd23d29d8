// `scan synth`: a synthetic population of cleaned head scans with ground truth (docs/pipeline.md). Each subject is the
// template deformed by a sampled identity (scan/identity.h), remeshed into its own topology so registration has real
// work to do, with the dense truth correspondence: for every template vertex, its true point on the scan's surface.
//
// Each scan also gets its own UV atlas (two charts cut along the facial midline, warped, rotated and packed differently
// per subject) and the four skin maps in it (scan/skin_bake.h), evaluated from a per-subject procedural skin whose
// true value at any surface point is known (scan/skin.h). Realism knobs: measurement noise, nostril holes, similarity
// jitter. Expression blendshapes on the template are in scan/blendshapes.h.
#pragma once
#include <cstdint>
#include <string>

#include "core/landmarks.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "template/template_face.h"
#include "scan/identity.h"
#include "scan/skin.h"
#include "scan/skin_bake.h"

namespace bareskin {

struct SynthOptions {
  int count = 8;                  // subjects
  uint64_t seed = 1;              // population seed; subject i's seed derives from (seed, i)
  int scan_vertices = 100000;     // about 200k triangles, each scan in its own topology
  int remesh_iterations = 1;
  IdentityOptions identity;
  // Realism knobs (0 = off). Noise moves scan vertices along their normals; jitter applies a random similarity
  // (uniform scale in [1-s, 1+s], rotation up to `rotation_jitter_deg` about a random axis, translation up to
  // `translation_jitter_mm` per axis) to the whole scan, as a scanner's own frame would.
  double noise_mm = 0;
  double scale_jitter = 0;
  double rotation_jitter_deg = 0;
  double translation_jitter_mm = 0;
  bool holes = false;             // cut the nostrils open, as structured-light scanners leave them
  double skin_detail = 0;         // Appearance::detail of every subject (0..1; on for synthetic captures)
  // Maps in each scan's atlas (resolution 0: none) and, optionally, the truth maps in the template UV.
  BakeOptions maps;
  int truth_resolution = 0;
  void check() const;
};

struct SyntheticScan {
  std::string id;               // "subject_0007"
  Identity identity;
  Mesh mesh;                    // the scan: own vertices, triangles and UV atlas, mm (after noise and jitter)
  Appearance appearance;        // the skin its maps are baked from
  SkinSurface surface;          // the scan before noise and jitter, with each vertex's template point and UV
  Landmarks landmarks;          // 68 iBUG points on the scan surface, mm
  // Truth correspondence, one row per template vertex: the face of `mesh` it lies on, barycentric weights of that
  // face's corners, and the point itself. In a hole the face is -1 and the point is where the surface would be.
  Eigen::VectorXi truth_face;
  Eigen::MatrixX3d truth_barycentric;
  Eigen::MatrixX3d truth_point;
  // The similarity applied after remeshing: x_scan = scale * rotation * x + translation (identity when no jitter).
  double scale = 1;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

uint64_t subject_seed(uint64_t population_seed, int index);

// Subject `index` of the population; deterministic in (template, index, options).
SyntheticScan synthesize_scan(const TemplateFace& face, int index, const SynthOptions& options);

// The truth surface for maps in the template UV: the template deformed by `displacement`, with its own UV, evaluated
// at the template's points. Baking it gives what a perfect registration + texture transfer produces.
SkinSurface template_skin_surface(const TemplateFace& face, const Eigen::MatrixX3d& displacement);

// Writes dir/<id>/{mesh.obj, diffuse/normal/roughness/specular maps, landmarks.json, truth/correspondence.safetensors,
// truth/identity.json, truth/maps/ when asked} atomically (a killed run leaves no partial subject).
void write_scan(const std::string& dir, const TemplateFace& face, const SyntheticScan& scan, const SynthOptions& options,
                const ProgressCallback& progress = {});

// `bareskin scan synth`: a population in `output`.
struct PopulationOptions {
  std::string output = "scans";
  std::string template_dir;        // the template's folder ("": the default search), recorded in manifest.json
  std::string map_format = "png";  // as given (recorded in manifest.json); synth.maps.format holds it parsed
  SynthOptions synth;
  void check() const;              // InvalidInput naming the flag (synth.check())
};

// Checks the options, reads the template, then writes the subjects of options.synth that `output` does not hold yet
// (each appears whole, so a killed run resumes where it stopped), the template's blendshapes (blendshapes/) and
// manifest.json. `progress`: subjects done, or for a single subject its map bands.
void write_population(const PopulationOptions& options, const ProgressCallback& progress = {});

}  // namespace bareskin
