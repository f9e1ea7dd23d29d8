// What the commands that take "a mesh, or a morphable model at some coefficients" (render, uvtools unwarp/mask) read,
// and the camera they frame it with; the coefficient file itself is morphable/coefficients.h.
#pragma once
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "render/camera.h"

namespace bareskin {

struct ModelInstance {
  Mesh mesh;                                   // posed, with the model's UVs
  Image appearance;                            // R x R linear RGB albedo from delta (empty without appearance model)
  std::optional<std::array<double, 27>> gamma;  // when the coefficients hold lighting
  std::vector<int> landmark_vertices;           // the model's 68
};

// InvalidInput naming the coefficient file for a malformed entry.
ModelInstance model_instance(const std::string& model_path, const std::string& coeffs_path);

// --mesh, or the model at the coefficients; InvalidInput unless exactly one is given.
Mesh posed_mesh(const std::string& mesh_path, const std::string& model_path, const std::string& coeffs_path);

// The "vertex_ids" of a landmark file (the template's landmarks.json) for `mesh`: InvalidInput naming the file when the
// list is missing, holds a non-integer or a vertex outside the mesh, or (count > 0) has another length.
std::vector<int> read_landmark_vertex_ids(const std::string& path, const Mesh& mesh, size_t count = 0);

// The camera of `render --camera` (also unwarp, mask): `camera` "pinhole" or "weak", a size x size image from `view`.
// A mesh is framed by its bounding box; a model (`fixed`) sits in a fixed camera looking at its origin, its pose being
// part of the coefficients. Weak perspective fits the mesh to 80% of the frame.
Camera command_camera(const Mesh& mesh, bool fixed, const std::string& view, const std::string& camera, int size);

}  // namespace bareskin
