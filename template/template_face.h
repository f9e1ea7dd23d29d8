// The template face: the fixed topology every scan is registered to and the 3DMM is built on.
// Built from the MediaPipe canonical face (468 vertices), converted to millimetres and our axes (docs/pipeline.md), and
// refined into a dense, evenly triangulated surface of a chosen size. Any user template (OBJ with UVs + landmark file)
// can take its place: see read_template.
#pragma once
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "core/progress.h"
#include "template/mediapipe_face.h"
#include "template/node_layout.h"

namespace bareskin {

struct TemplateFace {
  Mesh mesh;                                        // V in mm, UV per corner
  std::vector<int> landmark_vertices;               // 68 vertex ids, iBUG order
  std::map<std::string, std::vector<int>> regions;  // named vertex contours (lips, eyes, brows, silhouette)
  // NICP's node mesh for kDefaultNodes (the folder's nodes.safetensors when made for this mesh; else null).
  std::shared_ptr<const NodeLayout> nodes;
};

struct TemplateOptions {
  int target_vertices = 65000;  // the paper's 3DMM has 65,143 vertices
  int remesh_iterations = 3;    // isotropic remeshing passes (more: more regular triangles, slower)
  // Check(): throws InvalidInput when out of range.
  void check() const;
};

// The canonical face as a coarse template: cm -> mm, UV v flipped to OBJ's bottom-left origin, tables attached.
TemplateFace coarse_template(const CanonicalFace& face, const FaceMeshTables& tables);

// Refines a template whose UVs are one per vertex (no seams) to about options.target_vertices vertices: modified
// butterfly subdivision (interpolating, so the coarse surface is kept) then isotropic remeshing to an even edge length.
// UVs follow through the same subdivision of the UV layout; landmarks and regions go to the nearest new vertex.
TemplateFace refine_template(const TemplateFace& coarse, const TemplateOptions& options,
                             const ProgressCallback& progress = {});

// Writes dir/face.obj, dir/landmarks.json (3D points + "vertex_ids"), dir/regions.json, dir/face.safetensors
// (V, F, UV, FUV, landmark ids) for the Torch side, which reads no OBJ, and dir/nodes.safetensors (NICP's node mesh,
// node_layout.h, made from face.obj as read back) when the template is dense enough to use one.
void write_template(const std::string& dir, const TemplateFace& face, const std::string& provenance);

// Reads a template: an OBJ with UVs plus a landmark JSON holding either "vertex_ids" or 68 3D points (snapped to the
// nearest vertex). regions.json and nodes.safetensors beside the landmarks are optional.
TemplateFace read_template(const std::string& obj_path, const std::string& landmarks_path);

// The template folder (face.obj + landmarks.json) commands use: `given` (--template) if not empty, else the search
// path of core/assets.h (BARESKIN_TEMPLATE, then share/bareskin/template beside the executable); IoError listing the
// places searched when there is none.
std::string find_template_folder(const std::string& given);
TemplateFace read_template_folder(const std::string& given);

}  // namespace bareskin
