// A scan folder, as `scan synth`, `scan register` and the rigs' exports lay it out: mesh.ply or mesh.obj, and maps
// named by kind (diffuse.png|exr|tif|tiff, normal.*, ...). One place decides which file is which.
#pragma once
#include <optional>
#include <string>

#include "core/image.h"
#include "core/mesh.h"

namespace bareskin {

// The folder's mesh (mesh.ply, else mesh.obj), or "" when it has none.
std::string find_scan_mesh(const std::string& dir);

// The folder's map of this kind ("diffuse" → diffuse.png|exr|tif|tiff, first found), or "" when it has none.
std::string find_scan_map(const std::string& dir, const std::string& kind);

struct TexturedScan {
  Mesh mesh;
  std::optional<Image> diffuse;  // linear; absent when the scan has no diffuse map
  std::string mesh_path;
};

// A scan folder or a mesh file; `texture` (optional) overrides the folder's diffuse map. InvalidInput when a folder
// has no mesh, or when a diffuse map comes with a mesh without UVs.
TexturedScan read_textured_scan(const std::string& scan, const std::string& texture = "");

}  // namespace bareskin
