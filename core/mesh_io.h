// Mesh files through OpenMesh: OBJ (per-corner UVs kept) and PLY (ASCII or binary; per-vertex UVs only).
#pragma once
#include <string>

#include "core/mesh.h"

namespace bareskin {

// Reads .obj or .ply. Throws IoError (missing/unreadable) or InvalidInput (corrupt or truncated file, non-triangle
// or non-manifold faces, NaN/Inf vertices, UV indices out of range), naming the file.
Mesh read_mesh(const std::string& path);

struct MeshWriteOptions {
  bool binary = true;        // PLY only
  bool write_normals = true; // when the mesh has normals
  int precision = 9;         // significant digits in ASCII files
  void check() const;        // InvalidInput when precision is outside [1, 17]
};

// Writes .obj or .ply atomically. PLY holds one UV per vertex, so a mesh whose UVs have seams (FUV != F) must go to
// OBJ: InvalidInput says so.
void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options = {});

}  // namespace bareskin
