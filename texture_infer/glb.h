// glTF 2.0 binary (.glb) for an avatar: one triangle mesh with UVs, normals and tangents, and one PBR material —
// baseColor = the diffuse map (sRGB), the tangent-space normal map, roughness in the G channel of the
// metallicRoughness texture (metallic 0), and the specular strength through KHR_materials_specular (its texture's
// alpha channel). Positions in metres (glTF's unit; our meshes are in millimetres); texture coordinates with glTF's
// top-left origin. No Torch: JSON through nlohmann-json, PNG through core/png.h. docs/file_formats.md, "Avatar".
#pragma once
#include <string>

#include "core/image.h"
#include "core/mesh.h"

namespace bareskin::texture {

struct PbrMaps {
  Image diffuse;    // RGB, linear or sRGB (stored sRGB)
  Image normal;     // RGB tangent-space, (n + 1)/2, +Y up
  Image roughness;  // grey, perceptual GGX roughness
  Image specular;   // grey, specular strength (1 = glTF's dielectric default F0 0.04)
};

// The .glb bytes. InvalidInput when the mesh has no UVs or a map is missing.
std::string glb_bytes(const Mesh& mesh, const PbrMaps& maps);
// Writes them atomically.
void write_glb(const std::string& path, const Mesh& mesh, const PbrMaps& maps);

}  // namespace bareskin::texture
