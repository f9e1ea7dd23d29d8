#include "apps/model_input.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "morphable/model.h"

namespace bareskin::cli {

ModelInstance model_instance(const std::string& model_path, const std::string& coeffs_path) {
  if (coeffs_path.empty()) throw InvalidInput("", "--model needs --coeffs", "pass the fit's coefficients (JSON)");
  const MorphableModel model = read_model(model_path);
  const auto doc = nlohmann::json::parse(read_file(coeffs_path), nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) throw InvalidInput(coeffs_path, "is not a JSON object", "");
  const auto numbers = [&](const char* key, size_t expected) {
    std::vector<double> v;
    if (!doc.contains(key)) return std::vector<double>(expected, 0.0);
    if (!doc[key].is_array()) throw InvalidInput(coeffs_path, std::string(key) + " is not a list", "");
    for (const auto& x : doc[key]) {
      if (!x.is_number() || !std::isfinite(x.get<double>())) {
        throw InvalidInput(coeffs_path, std::string(key) + " holds a value that is not a finite number", "");
      }
      v.push_back(x.get<double>());
    }
    if (expected && v.size() != expected) {
      throw InvalidInput(coeffs_path, std::string(key) + " needs " + std::to_string(expected) + " numbers", "");
    }
    return v;
  };
  const auto vec = [](const std::vector<double>& v) {
    return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
  };
  const std::vector<double> a = numbers("alpha", 0), b = numbers("beta", 0), d = numbers("delta", 0),
                            r = numbers("rotation", 3), t = numbers("translation", 3);
  ModelInstance out;
  out.mesh = model.topology;
  out.mesh.V = model.shape(vec(a), vec(b));
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(r[2], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(r[1], Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(r[0], Eigen::Vector3d::UnitX())).toRotationMatrix();
  out.mesh.V = ((out.mesh.V * R.transpose()).rowwise() + Eigen::RowVector3d(t[0], t[1], t[2])).eval();
  out.mesh.N.resize(0, 3);
  out.landmark_vertices = model.landmark_vertices;
  if (model.appearance_resolution > 0 && model.appearance_mean.size() > 0) {
    const int R_ = model.appearance_resolution;
    out.appearance = Image(R_, R_, 3, ColorSpace::Linear);
    out.appearance.pixels = model.appearance(vec(d));
  }
  if (doc.contains("gamma")) {
    const std::vector<double> g = numbers("gamma", 27);
    std::array<double, 27> gamma{};
    std::copy(g.begin(), g.end(), gamma.begin());
    out.gamma = gamma;
  }
  return out;
}

std::vector<int> read_landmark_vertex_ids(const std::string& path, const Mesh& mesh, size_t count) {
  const auto doc = nlohmann::json::parse(read_file(path), nullptr, false);
  if (doc.is_discarded() || !doc.contains("vertex_ids") || !doc["vertex_ids"].is_array()) {
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
    throw InvalidInput("", "give a mesh, or --model with --coeffs", "see --help");
  }
  return mesh_path.empty() ? model_instance(model_path, coeffs_path).mesh : read_mesh(mesh_path);
}

}  // namespace bareskin::cli
