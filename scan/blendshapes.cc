#include "scan/blendshapes.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <functional>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/ibug68.h"
#include "core/files.h"
#include "core/safetensors.h"

namespace bareskin {
namespace {

// A local expression: vertices near the anchors (Gaussian falloff of the distance to the nearest anchor) move by
// `move` (mm). Sided shapes are defined for the subject's left; the right twin mirrors anchors and x.
struct Local {
  const char* name;
  std::vector<int> anchors;  // iBUG-68 indices on the subject's left (or central)
  double radius;             // mm
  Eigen::Vector3d move;      // mm
  bool sided;
};

const std::vector<Local>& locals() {
  // Anchors are given on the subject's left: brow 22-26, eye 42-47, mouth corner 54, nostril 35, cheek 13-14.
  static const std::vector<Local> table = {
      {"browDown", {22, 23, 24}, 10, {0, -3, -0.5}, true},
      {"browOuterUp", {25, 26}, 10, {0, 4, 0.5}, true},
      {"browInnerUp", {21, 22}, 9, {0, 4, 0.5}, false},
      {"cheekPuff", {12, 13}, 16, {0, 0, 5}, false},
      {"cheekSquint", {46, 47, 14}, 10, {0, 2.5, 1}, true},
      {"eyeBlink", {43, 44}, 5, {0, -3.5, 0.3}, true},
      {"eyeSquint", {46, 47}, 6, {0, 1.5, 0.3}, true},
      {"eyeWide", {43, 44}, 6, {0, 2, 0.5}, true},
      {"eyeLookUp", {43, 44, 46, 47}, 6, {0, 1.2, 0}, true},
      {"eyeLookDown", {43, 44, 46, 47}, 6, {0, -1.2, 0}, true},
      {"eyeLookIn", {42, 47}, 6, {-0.8, 0, 0}, true},
      {"eyeLookOut", {45, 46}, 6, {0.8, 0, 0}, true},
      {"noseSneer", {35, 42}, 8, {0, 3, 1}, true},
      {"mouthSmile", {54}, 11, {4, 5, 1}, true},
      {"mouthFrown", {54}, 11, {1, -4, 0}, true},
      {"mouthDimple", {54}, 8, {2, 0, -2.5}, true},
      {"mouthStretch", {54, 55}, 10, {5, -2, -1}, true},
      {"mouthPress", {53, 55, 64}, 6, {0, 0, -1.5}, true},
      {"mouthUpperUp", {52, 53}, 7, {0, 3.5, 1}, true},
      {"mouthLowerDown", {55, 56}, 7, {0, -3.5, 0.5}, true},
      {"mouthLeft", {48, 51, 54, 57}, 14, {5, 0, 0}, false},
      {"mouthPucker", {49, 50, 51, 52, 53, 55, 56, 57, 58, 59}, 9, {0, 0, 5}, false},
      {"mouthFunnel", {50, 51, 52, 56, 57, 58}, 8, {0, 0, 4}, false},
      {"mouthRollUpper", {50, 51, 52}, 6, {0, -2, -2}, false},
      {"mouthRollLower", {56, 57, 58}, 6, {0, 2, -2}, false},
      {"mouthShrugUpper", {50, 51, 52}, 7, {0, 2.5, 1}, false},
      {"mouthShrugLower", {56, 57, 58, 8}, 10, {0, 3, 1}, false},
      {"mouthClose", {57, 66}, 7, {0, 2.5, 0}, false},
      {"noseWrinkle", {27, 28}, 8, {0, -1.5, 0.5}, false},
  };
  return table;
}

// Smooth weight of the lower face for jaw motion: 1 below the mouth, 0 above the nose base, smoothstep between.
double jaw_weight(const Eigen::Vector3d& p, double y_full, double y_none) {
  const double t = std::clamp((y_none - p.y()) / (y_none - y_full), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

}  // namespace

std::vector<Blendshape> make_blendshapes(const TemplateFace& face) {
  if (face.landmark_vertices.size() != 68) {
    throw InvalidInput("template", "needs the 68 iBUG landmark vertices for blendshapes", "give a landmark file");
  }
  const Eigen::MatrixX3d& V = face.mesh.V;
  const auto landmark = [&](int i) -> Eigen::Vector3d { return V.row(face.landmark_vertices[size_t(i)]).transpose(); };
  std::vector<Blendshape> shapes;

  const auto add_local = [&](const std::string& name, const std::vector<int>& anchors, double radius,
                             const Eigen::Vector3d& move) {
    Blendshape b{name, Eigen::MatrixX3d::Zero(V.rows(), 3)};
    for (Eigen::Index i = 0; i < V.rows(); ++i) {
      double d2 = 1e30;
      for (int a : anchors) d2 = std::min(d2, (V.row(i).transpose() - landmark(a)).squaredNorm());
      b.delta.row(i) = (std::exp(-d2 / (2 * radius * radius)) * move).transpose();
    }
    shapes.push_back(std::move(b));
  };
  for (const Local& l : locals()) {
    if (!l.sided) {
      if (std::string(l.name) == "mouthLeft") {
        add_local("mouthLeft", l.anchors, l.radius, l.move);
        add_local("mouthRight", l.anchors, l.radius, Eigen::Vector3d(-l.move.x(), l.move.y(), l.move.z()));
      } else {
        add_local(l.name, l.anchors, l.radius, l.move);
      }
      continue;
    }
    add_local(std::string(l.name) + "_L", l.anchors, l.radius, l.move);
    std::vector<int> mirrored;
    for (int a : l.anchors) mirrored.push_back(kIbug68Mirror[a]);
    add_local(std::string(l.name) + "_R", mirrored, l.radius, Eigen::Vector3d(-l.move.x(), l.move.y(), l.move.z()));
  }

  // Jaw: a rotation or shift of the lower face about the jaw hinge (between the ear-level contour points 1 and 15).
  const Eigen::Vector3d hinge = 0.5 * (landmark(1) + landmark(15)) - Eigen::Vector3d(0, 0, 15);
  const double y_full = landmark(57).y(), y_none = landmark(33).y();
  const auto add_jaw = [&](const std::string& name, const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& move) {
    Blendshape b{name, Eigen::MatrixX3d::Zero(V.rows(), 3)};
    for (Eigen::Index i = 0; i < V.rows(); ++i) {
      const Eigen::Vector3d p = V.row(i).transpose();
      b.delta.row(i) = (jaw_weight(p, y_full, y_none) * move(p)).transpose();
    }
    shapes.push_back(std::move(b));
  };
  const Eigen::Matrix3d open = Eigen::AngleAxisd(0.15, Eigen::Vector3d::UnitX()).toRotationMatrix();  // ~9 degrees: chin ~19 mm
  add_jaw("jawOpen", [&](const Eigen::Vector3d& p) -> Eigen::Vector3d { return open * (p - hinge) + hinge - p; });
  add_jaw("jawForward", [](const Eigen::Vector3d&) -> Eigen::Vector3d { return {0, 0, 4}; });
  add_jaw("jawLeft", [](const Eigen::Vector3d&) -> Eigen::Vector3d { return {4, 0, 0}; });
  add_jaw("jawRight", [](const Eigen::Vector3d&) -> Eigen::Vector3d { return {-4, 0, 0}; });
  return shapes;
}

void write_blendshapes(const std::string& dir, const std::vector<Blendshape>& shapes) {
  if (shapes.empty()) throw InternalError("write_blendshapes: no shapes");
  const int64_t k = int64_t(shapes.size()), n = shapes.front().delta.rows();
  std::vector<float> deltas(size_t(k * n * 3));
  nlohmann::json names = nlohmann::json::array();
  for (int64_t s = 0; s < k; ++s) {
    names.push_back(shapes[size_t(s)].name);
    for (int64_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) deltas[size_t((s * n + i) * 3 + c)] = float(shapes[size_t(s)].delta(i, c));
  }
  SafeTensorsWriter w;
  w.add("deltas", {k, n, 3}, deltas);
  w.set_metadata("format", "bareskin.blendshapes");
  w.set_metadata("format_version", "1");
  w.set_metadata("units", "mm");
  w.set_metadata("names", names.dump());
  make_directories(dir);
  w.write(dir + "/blendshapes.safetensors");
  write_file_atomic(dir + "/names.json", names.dump(1) + "\n");
}

std::vector<Blendshape> read_blendshapes(const std::string& path) {
  const SafeTensors st = SafeTensors::open(path);
  const TensorView& t = st.tensor("deltas", DType::F32, {-1, -1, 3});
  const auto& meta = st.metadata();
  std::vector<std::string> names;
  if (meta.count("names")) {
    try {
      names = nlohmann::json::parse(meta.at("names")).get<std::vector<std::string>>();
    } catch (const std::exception&) {
      throw InvalidInput(path, "metadata 'names' is not a JSON list of strings", "write it with one name per shape");
    }
  }
  if (!names.empty() && int64_t(names.size()) != t.shape[0]) {
    throw InvalidInput(path, "has " + std::to_string(t.shape[0]) + " shapes but " + std::to_string(names.size()) + " names", "");
  }
  const std::vector<float> v = t.to_vector<float>();
  std::vector<Blendshape> shapes(static_cast<size_t>(t.shape[0]));
  for (int64_t s = 0; s < t.shape[0]; ++s) {
    Blendshape& b = shapes[size_t(s)];
    b.name = names.empty() ? "shape_" + std::to_string(s) : names[size_t(s)];
    b.delta = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(v.data() + s * t.shape[1] * 3,
                                                                                         t.shape[1], 3).cast<double>();
    if (!b.delta.allFinite()) throw InvalidInput(path, b.name + " holds NaN or Inf", "");
  }
  return shapes;
}

}  // namespace bareskin
