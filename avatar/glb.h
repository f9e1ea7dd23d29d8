// glTF 2.0 binary (.glb) for an avatar: one triangle mesh with UVs, normals and tangents, and one PBR material —
// baseColor = the diffuse map (sRGB), the tangent-space normal map, roughness in the G channel of the
// metallicRoughness texture (metallic 0: the grey roughness PNG itself), and the specular strength through
// KHR_materials_specular (its texture's alpha channel). Positions in metres (glTF's unit; our meshes are in millimetres); texture coordinates with glTF's
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

// The four textures as PNG files' bytes, so that an avatar folder's map files and its GLB share one encoding:
// - diffuse: RGB, sRGB; normal: RGB;
// - metallic_roughness: any PNG whose G channel is the roughness. The grey roughness map's own PNG serves: a grey
//   image is read as R = G = B = grey, and the metallic value read from B is multiplied by metallicFactor 0;
// - specular: the strength in the alpha channel (specular_texture's grey + alpha PNG).
struct PbrPngs {
  std::string diffuse, normal, metallic_roughness, specular;
};
// What KHR_materials_specular reads the strength from: grey 1 (white) with the strength as alpha.
Image specular_texture(const Image& specular);

// The .glb bytes. InvalidInput when the mesh has no UVs, a map is missing or a texture is not PNG data.
std::string glb_bytes(const Mesh& mesh, const PbrPngs& textures);
std::string glb_bytes(const Mesh& mesh, const PbrMaps& maps);  // encodes the maps (roughness as grey, see above)
// Writes them atomically.
void write_glb(const std::string& path, const Mesh& mesh, const PbrPngs& textures);
void write_glb(const std::string& path, const Mesh& mesh, const PbrMaps& maps);

}  // namespace bareskin::texture
