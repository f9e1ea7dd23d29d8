#include "morphable/model.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/safetensors.h"

namespace bareskin {
namespace {

constexpr const char* kFormat = "bareskin.morphable_model";
constexpr const char* kVersion = "1";

// U diag(σ) c for the first c.size() rows of U (c may be shorter than the basis).
Eigen::VectorXd combine(const RowMatrixXf& basis, const Eigen::VectorXf& stddev, const Eigen::VectorXd& c,
                        const char* what) {
  if (c.size() > basis.rows()) {
    throw InvalidInput("", std::string(what) + ": " + std::to_string(c.size()) + " coefficients, the model has " +
                               std::to_string(basis.rows()), "give at most as many coefficients as components");
  }
  if (!c.allFinite()) throw InvalidInput("", std::string(what) + ": coefficients are not finite", "");
  Eigen::VectorXd out = Eigen::VectorXd::Zero(basis.cols());
  for (Eigen::Index k = 0; k < c.size(); ++k) out += (c(k) * stddev(k)) * basis.row(k).transpose().cast<double>();
  return out;
}

template <class T>
std::vector<T> values(const SafeTensors& st, const std::string& name, DType dtype, const std::vector<int64_t>& shape) {
  return st.tensor(name, dtype, shape).to_vector<T>();
}

// A [K, ...tail] tensor as K rows.
RowMatrixXf matrix(const SafeTensors& st, const std::string& name, std::vector<int64_t> tail) {
  int64_t cols = 1;
  for (int64_t e : tail) cols *= e;
  tail.insert(tail.begin(), -1);
  const TensorView& t = st.tensor(name, DType::F32, tail);
  const std::vector<float> v = t.to_vector<float>();
  RowMatrixXf m = Eigen::Map<const RowMatrixXf>(v.data(), t.shape[0], cols);
  if (!m.allFinite()) throw InvalidInput(st.source(), name + " holds NaN or Inf", "rebuild the model");
  return m;
}

Eigen::VectorXf vector(const SafeTensors& st, const std::string& name, int64_t n) {
  const std::vector<float> v = values<float>(st, name, DType::F32, {n});
  return Eigen::Map<const Eigen::VectorXf>(v.data(), Eigen::Index(v.size()));
}

}  // namespace

Eigen::MatrixX3d MorphableModel::shape(const Eigen::VectorXd& alpha, const Eigen::VectorXd& beta) const {
  Eigen::VectorXd s = combine(shape_basis, shape_stddev, alpha, "shape (alpha)");
  if (beta.size() > 0) s += combine(expression_basis, expression_stddev, beta, "expression (beta)");
  Eigen::MatrixX3d S = topology.V;
  S += Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(s.data(), topology.V.rows(), 3);
  return S;
}

std::vector<float> MorphableModel::appearance(const Eigen::VectorXd& delta) const {
  const Eigen::VectorXf a = appearance_mean + combine(appearance_basis, appearance_stddev, delta, "appearance (delta)").cast<float>();
  return std::vector<float>(a.data(), a.data() + a.size());
}

void write_model(const std::string& path, const MorphableModel& m) {
  const int64_t V = m.vertices(), F = m.topology.F.rows(), R = m.appearance_resolution;
  SafeTensorsWriter w;
  const auto add_rows = [&](const std::string& name, const RowMatrixXf& basis, std::vector<int64_t> tail) {
    tail.insert(tail.begin(), basis.rows());
    w.add(name, DType::F32, tail, basis.data(), size_t(basis.size()) * sizeof(float));
  };
  const RowMatrixXf mean = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>(m.topology.V).cast<float>();
  w.add("shape_mean", DType::F32, {V, 3}, mean.data(), size_t(mean.size()) * sizeof(float));
  add_rows("shape_basis", m.shape_basis, {V, 3});
  w.add("shape_stddev", DType::F32, {m.shape_stddev.size()}, m.shape_stddev.data(), size_t(m.shape_stddev.size()) * 4);
  add_rows("expression_basis", m.expression_basis, {V, 3});
  w.add("expression_stddev", DType::F32, {m.expression_stddev.size()}, m.expression_stddev.data(),
        size_t(m.expression_stddev.size()) * 4);
  w.add("appearance_mean", DType::F32, {R, R, 3}, m.appearance_mean.data(), size_t(m.appearance_mean.size()) * 4);
  add_rows("appearance_basis", m.appearance_basis, {R, R, 3});
  w.add("appearance_stddev", DType::F32, {m.appearance_stddev.size()}, m.appearance_stddev.data(),
        size_t(m.appearance_stddev.size()) * 4);
  w.add("appearance_mask", DType::U8, {R, R}, m.appearance_mask.data(), m.appearance_mask.size());
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> tri = m.topology.F, uvtri = m.topology.FUV;
  const Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor> uv = m.topology.UV.cast<float>();
  w.add("triangles", DType::I32, {F, 3}, tri.data(), size_t(tri.size()) * 4);
  w.add("uvs", DType::F32, {uv.rows(), 2}, uv.data(), size_t(uv.size()) * 4);
  w.add("uv_triangles", DType::I32, {F, 3}, uvtri.data(), size_t(uvtri.size()) * 4);
  std::vector<int32_t> landmarks(m.landmark_vertices.begin(), m.landmark_vertices.end());
  w.add("landmark_vertices", std::vector<int64_t>{int64_t(landmarks.size())}, landmarks);
  w.add("vertex_region", DType::U8, {V}, m.vertex_region.data(), m.vertex_region.size());
  std::vector<float> gpa;
  for (const Eigen::Matrix4d& T : m.procrustes)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) gpa.push_back(float(T(r, c)));
  w.add("procrustes", std::vector<int64_t>{int64_t(m.procrustes.size()), 4, 4}, gpa);

  for (const auto& [key, value] : m.metadata) w.set_metadata(key, value);
  w.set_metadata("format", kFormat);
  w.set_metadata("format_version", kVersion);
  w.set_metadata("units", "mm");
  w.set_metadata("colour_space", "linear RGB (sRGB primaries), appearance in [0, 1]");
  w.set_metadata("coefficients", "standardised: S = shape_mean + sum_k alpha_k shape_stddev_k shape_basis_k (+ the "
                                 "same for expression with beta); A = appearance_mean + sum_k delta_k appearance_stddev_k "
                                 "appearance_basis_k; bases are orthonormal");
  w.set_metadata("components", nlohmann::json{{"shape", m.shape_basis.rows()},
                                              {"expression", m.expression_basis.rows()},
                                              {"appearance", m.appearance_basis.rows()}}.dump());
  w.set_metadata("region_names", nlohmann::json(m.region_names).dump());
  w.set_metadata("expression_names", nlohmann::json(m.expression_names).dump());
  w.set_metadata("subjects", nlohmann::json(m.subjects).dump());
  w.set_metadata("appearance_image", "row 0 is the top of the UV square (v = 1), columns along u");
  w.write(path);
}

MorphableModel read_model(const std::string& path) {
  const SafeTensors st = SafeTensors::open(path);
  const auto& meta = st.metadata();
  if (!meta.count("format") || meta.at("format") != kFormat) {
    throw InvalidInput(path, "is not a BareSkin morphable model (metadata format != bareskin.morphable_model)",
                       "give the file 'bareskin mm-build' wrote");
  }
  if (meta.at("format_version") != kVersion) {
    throw InvalidInput(path, "model format version " + meta.at("format_version") + ", this build reads " + kVersion,
                       "rebuild the model with this version");
  }
  MorphableModel m;
  m.metadata = meta;
  const int64_t V = st.tensor("shape_mean").shape.at(0), F = st.tensor("triangles").shape.at(0);
  const std::vector<float> mean = values<float>(st, "shape_mean", DType::F32, {V, 3});
  m.topology.V = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>>(mean.data(), V, 3).cast<double>();
  const std::vector<int32_t> tri = values<int32_t>(st, "triangles", DType::I32, {F, 3});
  m.topology.F = Eigen::Map<const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>>(tri.data(), F, 3);
  const int64_t T = st.tensor("uvs").shape.at(0);
  const std::vector<float> uv = values<float>(st, "uvs", DType::F32, {T, 2});
  m.topology.UV = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor>>(uv.data(), T, 2).cast<double>();
  const std::vector<int32_t> uvtri = values<int32_t>(st, "uv_triangles", DType::I32, {F, 3});
  m.topology.FUV = Eigen::Map<const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor>>(uvtri.data(), F, 3);
  validate(m.topology, path);

  m.shape_basis = matrix(st, "shape_basis", {V, 3});
  m.shape_stddev = vector(st, "shape_stddev", m.shape_basis.rows());
  m.expression_basis = matrix(st, "expression_basis", {V, 3});
  m.expression_stddev = vector(st, "expression_stddev", m.expression_basis.rows());
  const int64_t R = st.tensor("appearance_mean").shape.at(0);
  m.appearance_resolution = int(R);
  const std::vector<float> amean = values<float>(st, "appearance_mean", DType::F32, {R, R, 3});
  m.appearance_mean = Eigen::Map<const Eigen::VectorXf>(amean.data(), Eigen::Index(amean.size()));
  m.appearance_basis = matrix(st, "appearance_basis", {R, R, 3});
  m.appearance_stddev = vector(st, "appearance_stddev", m.appearance_basis.rows());
  m.appearance_mask = values<uint8_t>(st, "appearance_mask", DType::U8, {R, R});
  for (int32_t v : values<int32_t>(st, "landmark_vertices", DType::I32, {68})) {
    if (v < 0 || v >= V) throw InvalidInput(path, "landmark_vertices out of range", "rebuild the model");
    m.landmark_vertices.push_back(v);
  }
  m.vertex_region = values<uint8_t>(st, "vertex_region", DType::U8, {V});
  const std::vector<float> gpa = values<float>(st, "procrustes", DType::F32, {-1, 4, 4});
  for (size_t i = 0; i + 16 <= gpa.size(); i += 16) {
    Eigen::Matrix4d G;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) G(r, c) = gpa[i + size_t(4 * r + c)];
    m.procrustes.push_back(G);
  }
  const auto list = [&](const char* key) {
    return meta.count(key) ? nlohmann::json::parse(meta.at(key)).get<std::vector<std::string>>()
                           : std::vector<std::string>();
  };
  m.region_names = list("region_names");
  m.expression_names = list("expression_names");
  m.subjects = list("subjects");
  if (!m.topology.V.allFinite() || !m.appearance_mean.allFinite()) {
    throw InvalidInput(path, "the mean shape or appearance holds NaN or Inf", "rebuild the model");
  }
  return m;
}

void pose_blendshapes(Mesh& mesh, const std::string& blendshapes, const std::vector<std::string>& expression) {
  if (!expression.empty() && blendshapes.empty()) {
    throw InvalidInput("", "--expression needs --blendshapes FILE", "pass scans/blendshapes/blendshapes.safetensors");
  }
  if (blendshapes.empty()) return;
  const SafeTensors st = SafeTensors::open(blendshapes);
  const TensorView& deltas = st.tensor("deltas", DType::F32, {-1, mesh.V.rows(), 3});
  const auto names = nlohmann::json::parse(st.metadata().count("names") ? st.metadata().at("names") : "", nullptr, false);
  if (names.is_discarded() || !names.is_array() || int64_t(names.size()) != deltas.shape[0]) {
    throw InvalidInput(blendshapes, "metadata 'names' does not list the blendshapes", "rewrite it with 'scan synth'");
  }
  const std::vector<float> d = deltas.to_vector<float>();
  for (const std::string& item : expression) {
    const size_t eq = item.find('=');
    const std::string name = item.substr(0, eq);
    double weight = 1.0;
    if (eq != std::string::npos) {
      try {
        weight = std::stod(item.substr(eq + 1));
      } catch (const std::exception&) {
        throw InvalidInput("", "--expression '" + item + "': weight is not a number", "write NAME=WEIGHT");
      }
    }
    const auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end()) throw InvalidInput(blendshapes, "has no blendshape '" + name + "'", "see its names.json");
    const size_t k = size_t(it - names.begin()), n = size_t(mesh.V.rows());
    for (size_t i = 0; i < n; ++i)
      for (int c = 0; c < 3; ++c) mesh.V(Eigen::Index(i), c) += weight * d[(k * n + i) * 3 + size_t(c)];
  }
  mesh.N.resize(0, 3);  // recomputed for the posed shape
}

}  // namespace bareskin
