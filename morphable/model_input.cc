#include "morphable/model_input.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "morphable/coefficients.h"
#include "morphable/model.h"

namespace bareskin {

ModelInstance model_instance(const std::string& model_path, const std::string& coeffs_path) {
  if (coeffs_path.empty()) throw InvalidInput("", "--model needs --coeffs", "pass the fit's coefficients (JSON)");
  const MorphableModel model = read_model(model_path);
  const Coefficients c = read_coefficients(coeffs_path);
  ModelInstance out;
  out.mesh = posed_mesh(model, c);
  out.landmark_vertices = model.landmark_vertices;
  out.appearance = appearance_image(model, c);
  out.gamma = c.gamma;
  return out;
}

std::vector<int> read_landmark_vertex_ids(const std::string& path, const Mesh& mesh, size_t count) {
  const auto doc = nlohmann::json::parse(read_file(path), nullptr, false);
  if (doc.is_discarded()) throw InvalidInput(path, "is not JSON (empty or truncated?)", "pass the template's landmarks.json");
  if (!doc.contains("vertex_ids") || !doc["vertex_ids"].is_array()) {
    throw InvalidInput(path, "has no \"vertex_ids\" list", "pass the template's landmarks.json");
  }
  if (count > 0 && doc["vertex_ids"].size() != count) {
    throw InvalidInput(path, "has " + std::to_string(doc["vertex_ids"].size()) + " \"vertex_ids\", not " + std::to_string(count),
                       "pass the template's landmarks.json");
  }
  std::vector<int> ids;
  for (const auto& id : doc["vertex_ids"]) {
    if (!id.is_number_integer() || id.get<int64_t>() < 0 || id.get<int64_t>() >= mesh.V.rows()) {
      throw InvalidInput(path, "\"vertex_ids\" holds a non-integer or a vertex outside the mesh", "use the mesh's own landmarks");
    }
    ids.push_back(id.get<int>());
  }
  return ids;
}

Camera command_camera(const Mesh& mesh, bool fixed, const std::string& view, const std::string& camera, int size) {
  const Eigen::RowVector3d lo = mesh.V.colwise().minCoeff(), hi = mesh.V.colwise().maxCoeff();
  Camera cam = view_camera(view, size, fixed ? Eigen::Vector3d::Zero() : Eigen::Vector3d(0.5 * (lo + hi).transpose()));
  if (camera == "weak") {
    cam.model = Camera::Model::WeakPerspective;
    cam.scale = 0.8 * size / std::max((hi - lo).maxCoeff(), 1e-9);
  }
  return cam;
}

Mesh posed_mesh(const std::string& mesh_path, const std::string& model_path, const std::string& coeffs_path) {
  if (mesh_path.empty() == model_path.empty()) {
    throw InvalidInput("", mesh_path.empty() ? "give a mesh, or --model with --coeffs" : "give a mesh or --model, not both",
                       "see --help");
  }
  return mesh_path.empty() ? model_instance(model_path, coeffs_path).mesh : read_mesh(mesh_path);
}

}  // namespace bareskin
