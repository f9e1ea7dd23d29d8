// A triangle mesh as plain Eigen data (libigl style). Units are millimetres; right-handed, +y up, +z toward the camera
// (docs/pipeline.md). UVs are per corner, so seams survive a read/write round trip.
#pragma once
#include <Eigen/Core>
#include <string>

namespace bareskin {

struct Mesh {
  Eigen::MatrixX3d V;   // #V by 3 vertex positions
  Eigen::MatrixX3i F;   // #F by 3 vertex indices, counter-clockwise seen from outside
  Eigen::MatrixX2d UV;  // #UV by 2 texture coordinates, origin bottom-left; empty when the mesh has none
  Eigen::MatrixX3i FUV; // #F by 3 indices into UV per face corner; empty iff UV is empty
  Eigen::MatrixX3d N;   // #V by 3 unit vertex normals; empty when not computed or read

  bool has_uv() const { return UV.rows() > 0; }
  bool has_normals() const { return N.rows() > 0; }
};

// Throws InvalidInput naming `source` when: a vertex is NaN/Inf, a face index is out of range or repeats a vertex,
// FUV's shape does not match F, a UV index is out of range, a UV is NaN/Inf, or N's shape does not match V.
void validate(const Mesh& mesh, const std::string& source);

// Area-weighted unit vertex normals (#V by 3); isolated vertices get (0,0,0).
Eigen::MatrixX3d vertex_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

// Unit face normals (#F by 3); degenerate faces get (0,0,0).
Eigen::MatrixX3d face_normals(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

// Edges lying on exactly one face, as #E by 2 vertex index pairs oriented as in their face.
Eigen::MatrixX2i boundary_edges(const Eigen::MatrixX3i& F);

// True when every vertex has a single UV value (no seams); then `uv` (#V by 2) holds it. Compares values, not
// indices, so a seamless mesh read back from OBJ (where indices are renumbered) counts as seamless.
bool per_vertex_uv(const Mesh& mesh, Eigen::MatrixX2d& uv);

// Tangent frames for tangent-space normal maps, MikkTSpace-style: per UV index (so seams split them), the
// area-weighted sum of the faces' dP/du, made orthogonal to the vertex normal; #UV by 4 with the unit tangent in
// xyz and the handedness (+1/-1) in w, so that the bitangent is w * cross(N, T) (+v = +y, OpenGL convention).
// Needs UVs and normals (InvalidInput otherwise). UV indices on degenerate faces only get a zero tangent.
Eigen::MatrixX4d uv_tangents(const Mesh& mesh);

// The tangent frame at a point of face f (barycentrics b): columns tangent, bitangent, normal, interpolated from the
// vertex normals and `tangents` (uv_tangents of the same mesh) and made orthonormal. World normal = frame * tangent-space
// normal; tangent-space = frame^T * world.
Eigen::Matrix3f tangent_frame(const Mesh& mesh, const Eigen::MatrixX4d& tangents, int f, const Eigen::Vector3f& b);

// Total surface area.
double surface_area(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F);

}  // namespace bareskin
