// The avatar with its four maps under a light (`bareskin relight`, the makeup previews): one rasterization, then per
// pixel the tangent-space normal map, diffuse = albedo × S(n) of the SH light (render/light.h), and a GGX specular
// lobe (roughness map: perceptual roughness r, α = r²; specular map: F0 = 0.04 × strength, glTF's
// KHR_materials_specular) from the light's key: the given key light, else the SH light's dominant direction. All in
// the model frame, so the light stays on the head when the camera turns. Linear light; the caller encodes.
#pragma once
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "render/camera.h"
#include "render/light.h"
#include "render/shade.h"

namespace bareskin {

struct PbrMapsView {
  const Image* diffuse = nullptr;    // linear RGB, required
  const Image* normal = nullptr;     // (n + 1) / 2 tangent space, +Y = +v; null: the mesh's normals
  const Image* roughness = nullptr;  // grey; null: 0.5
  const Image* specular = nullptr;   // grey; null: 1
};

struct PbrLight {
  ShLight sh{};
  KeyLight key;  // zero direction: dominant_light(sh)
};

// InvalidInput when the mesh has no UVs or is empty, or the diffuse map is missing or not linear colour.
Frame render_pbr(const Mesh& mesh, const Camera& camera, const PbrMapsView& maps, const PbrLight& light);

// render_pbr in two steps, for many renders of one view: the rasterization with the normal map applied, once, then
// shade() per set of maps and light (the maps' normal map is not used: the scene's is). The same pixels as
// render_pbr, which is PbrScene(mesh, camera, maps.normal).shade(maps, light).
class PbrScene {
 public:
  PbrScene(const Mesh& mesh, const Camera& camera, const Image* normal_map);
  Frame shade(const PbrMapsView& maps, const PbrLight& light) const;

 private:
  int width_ = 0, height_ = 0;
  std::vector<int64_t> pixel_;          // the covered pixels, row-major indices
  std::vector<double> n_, v_, uv_;      // per covered pixel: shading normal, direction to the eye, UV
  std::vector<float> depth_;
};

// A camera `distance` mm from `target` turned by yaw (about +y, degrees; positive shows the face's left) then pitch
// (about +x; positive looks from above), size² pixels, the lens of view_camera.
Camera orbit_camera(int size, double yaw_deg, double pitch_deg, const Eigen::Vector3d& target, double distance = 1000);

}  // namespace bareskin
