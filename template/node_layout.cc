#include "template/node_layout.h"

#include <cstdlib>
#include <string>

#include "core/error.h"
#include "core/hash.h"
#include "core/parallel.h"
#include "core/safetensors.h"
#include "template/surface.h"

namespace bareskin {

uint64_t node_layout_fingerprint(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int nodes) {
  const uint64_t h = fnv1a(V.data(), sizeof(double) * size_t(V.size()), kFnv1aBasis ^ uint64_t(nodes));
  return fnv1a(F.data(), sizeof(int) * size_t(F.size()), h);
}

bool uses_node_mesh(int64_t template_vertices, int nodes) {
  return nodes > 0 && template_vertices > nodes + nodes / 5;
}

NodeLayout make_node_layout(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int nodes) {
  NodeLayout layout;
  layout.template_fingerprint = node_layout_fingerprint(V, F, nodes);
  Eigen::MatrixX3d Vn;
  isotropic_remesh(V, F, nodes, 3, Vn, layout.F);
  const SurfaceLocator on_template(V, F), on_nodes(Vn, layout.F);
  layout.face.resize(size_t(Vn.rows()));
  layout.on_face.resize(size_t(Vn.rows()));
  for (Eigen::Index j = 0; j < Vn.rows(); ++j) {
    const SurfacePoint p = on_template.locate(Vn.row(j).transpose());
    layout.face[size_t(j)] = p.face;
    layout.on_face[size_t(j)] = p.barycentric;
  }
  layout.node.resize(size_t(V.rows()));
  layout.weight.resize(size_t(V.rows()));
  parallel_for(0, V.rows(), [&](int64_t b0, int64_t b1) {
    for (int64_t i = b0; i < b1; ++i) {
      const SurfacePoint p = on_nodes.locate(V.row(i).transpose());
      layout.node[size_t(i)] = {layout.F(p.face, 0), layout.F(p.face, 1), layout.F(p.face, 2)};
      layout.weight[size_t(i)] = p.barycentric;
    }
  }, 1024);
  return layout;
}

namespace {

template <class T, class Row>
std::vector<T> flatten(const std::vector<Row>& rows) {
  std::vector<T> out;
  out.reserve(3 * rows.size());
  for (const Row& r : rows)
    for (int k = 0; k < 3; ++k) out.push_back(T(r[k]));
  return out;
}

}  // namespace

void write_node_layout(const std::string& path, const NodeLayout& layout) {
  SafeTensorsWriter st;
  const int64_t nodes = int64_t(layout.face.size()), n = int64_t(layout.node.size());
  std::vector<int32_t> tri(size_t(layout.F.size()));
  for (Eigen::Index i = 0; i < layout.F.rows(); ++i)
    for (int k = 0; k < 3; ++k) tri[size_t(3 * i + k)] = layout.F(i, k);
  st.add("node_triangles", {int64_t(layout.F.rows()), 3}, tri);
  st.add("node_face", {nodes}, std::vector<int32_t>(layout.face.begin(), layout.face.end()));
  st.add("node_on_face", {nodes, 3}, flatten<double>(layout.on_face));
  st.add("vertex_nodes", {n, 3}, flatten<int32_t>(layout.node));
  st.add("vertex_weights", {n, 3}, flatten<double>(layout.weight));
  st.set_metadata("format", "bareskin.node_layout");
  st.set_metadata("format_version", "1");
  st.set_metadata("template_fingerprint", std::to_string(layout.template_fingerprint));
  st.write(path);
}

NodeLayout read_node_layout(const std::string& path) {
  const SafeTensors st = SafeTensors::open(path);
  const auto& meta = st.metadata();
  const auto fp = meta.find("template_fingerprint");
  if (meta.count("format") == 0 || meta.at("format") != "bareskin.node_layout" || fp == meta.end())
    throw InvalidInput(path, "is not a node layout (format bareskin.node_layout)", "remake the template folder with `bareskin template`");
  NodeLayout layout;
  char* end = nullptr;
  layout.template_fingerprint = std::strtoull(fp->second.c_str(), &end, 10);
  if (fp->second.empty() || *end != '\0')
    throw InvalidInput(path, "its template_fingerprint is not a number", "remake the template folder with `bareskin template`");
  const std::vector<int32_t> tri = st.tensor("node_triangles", DType::I32, {-1, 3}).to_vector<int32_t>();
  const std::vector<int32_t> face = st.tensor("node_face", DType::I32, {-1}).to_vector<int32_t>();
  const int64_t nodes = int64_t(face.size());
  const std::vector<double> on_face = st.tensor("node_on_face", DType::F64, {nodes, 3}).to_vector<double>();
  const std::vector<int32_t> node = st.tensor("vertex_nodes", DType::I32, {-1, 3}).to_vector<int32_t>();
  const std::vector<double> weight =
      st.tensor("vertex_weights", DType::F64, {int64_t(node.size() / 3), 3}).to_vector<double>();
  for (const int32_t v : tri)
    if (v < 0 || v >= nodes) throw InvalidInput(path, "a node triangle names a node that is not there", "remake it");
  for (const int32_t v : node)
    if (v < 0 || v >= nodes) throw InvalidInput(path, "a vertex names a node that is not there", "remake it");
  layout.F.resize(Eigen::Index(tri.size() / 3), 3);
  for (Eigen::Index i = 0; i < layout.F.rows(); ++i)
    for (int k = 0; k < 3; ++k) layout.F(i, k) = tri[size_t(3 * i + k)];
  layout.face.assign(face.begin(), face.end());
  for (size_t j = 0; j < face.size(); ++j)
    layout.on_face.emplace_back(on_face[3 * j], on_face[3 * j + 1], on_face[3 * j + 2]);
  for (size_t i = 0; i < node.size() / 3; ++i) {
    layout.node.push_back({node[3 * i], node[3 * i + 1], node[3 * i + 2]});
    layout.weight.emplace_back(weight[3 * i], weight[3 * i + 1], weight[3 * i + 2]);
  }
  return layout;
}

}  // namespace bareskin
