// An avatar folder as `bareskin run` writes it (docs/file_formats.md, "Avatar folder"), read and written by the
// commands that change or show an avatar after the fact (`makeup apply`, `relight`, the viewer): the mesh, the four
// maps at the net's size and, where made, at ×4. Geometry side only (no Torch).
#pragma once
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "render/light.h"
#include "render/pbr.h"

namespace bareskin::avatar_folder {

inline const std::array<const char*, 4> kMapNames = {"diffuse", "normal", "roughness", "specular"};

struct MapSet {
  Image diffuse;  // linear RGB
  Image normal;   // Data RGB
  Image roughness, specular;  // Data grey
  PbrMapsView view() const { return {&diffuse, &normal, &roughness, &specular}; }
};

struct Folder {
  std::string dir;
  Mesh mesh;
  MapSet maps;                   // maps/<map>.png
  std::optional<MapSet> maps_hr; // maps/<map>_hr.png, all four or none
  const MapSet& best() const { return maps_hr ? *maps_hr : maps; }
};

// InvalidInput naming the missing or wrong file (a map missing, of another size than the others, a mesh without UVs,
// only some of the _hr maps) with what to do; IoError when one cannot be read.
Folder read(const std::string& dir);

// Writes `folder`'s maps, the GLB from them (the ×4 maps where present), the three relit previews and `extra` files
// (relative path -> bytes) into `out` (an existing, empty folder being built, e.g. an AtomicDirectory's path), with
// every other file of the source folder `folder.dir` copied beside them (the aligned photo, coefficients, unwrap, ...).
// `previews`: the folder's previews(preview_lights()) when the caller has them, else empty (made at 512²).
// Returns the maps' PNG bytes by name ("diffuse", "roughness_hr", ...): encode_png(·, 8).
std::map<std::string, std::string> write(const std::string& out, const Folder& folder, const std::map<std::string, std::string>& extra,
           const std::vector<Image>& previews = {});

// The three preview lights of `bareskin run` (texgen's lights 0–2 of seed 2022: the default, then two random ones).
std::vector<ShLight> preview_lights();
// The avatar's best maps on its mesh, front view, under each light (sRGB).
std::vector<Image> previews(const Folder& folder, const std::vector<ShLight>& lights, int size);
// The same in two steps, for an avatar and its made-up copies (same mesh and normal map): the front view rasterized
// once at size², then `maps` under each light.
PbrScene preview_scene(const Folder& folder, int size);
std::vector<Image> previews(const PbrScene& scene, const MapSet& maps, const std::vector<ShLight>& lights);

// The fitted light of the photo: coefficients.json's gamma (InvalidInput when the folder has none).
ShLight photo_light(const std::string& dir);

}  // namespace bareskin::avatar_folder
