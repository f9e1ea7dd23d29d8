// The node mesh NICP deforms (scan/register.h): the template's rest surface remeshed to about `nodes` vertices, each
// node a point on a template triangle, and each template vertex embedded in a node triangle. Making it (a remesh of
// the dense template and two closest-point passes) costs seconds and depends only on the template, so `bareskin
// template` stores it beside the face as nodes.safetensors and a registration reads it instead of making it again.
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace bareskin {

constexpr int kDefaultNodes = 2000;  // NICP's default node count (RegisterOptions::nodes)

struct NodeLayout {
  uint64_t template_fingerprint = 0;     // of the rest V, F and the node count it was made for
  Eigen::MatrixX3i F;                    // node triangles
  std::vector<int> face;                 // per node: the template triangle it lies on
  std::vector<Eigen::Vector3d> on_face;  // ... and its barycentric weights there
  std::vector<std::array<int, 3>> node;  // per template vertex: its node triangle's corners
  std::vector<Eigen::Vector3d> weight;   // ... and barycentric weights
};

// The key a layout is made for: the bytes of V and F and the node count.
uint64_t node_layout_fingerprint(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int nodes);

// Whether NICP uses a node mesh for a template of this many vertices (else one affine per vertex).
bool uses_node_mesh(int64_t template_vertices, int nodes);

NodeLayout make_node_layout(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int nodes);

// nodes.safetensors: F, face, on_face, node, weight and the fingerprint (as metadata).
void write_node_layout(const std::string& path, const NodeLayout& layout);
// InvalidInput naming the file when a tensor is missing or its shape disagrees with the others.
NodeLayout read_node_layout(const std::string& path);

}  // namespace bareskin
