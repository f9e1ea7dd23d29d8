// The avatar with its four maps under a light (`bareskin relight`, the makeup previews): one rasterization, then per
// pixel the tangent-space normal map, diffuse = albedo × S(n) of the SH light (render/light.h), and a GGX specular
// lobe (roughness map: perceptual roughness r, α = r²; specular map: F0 = 0.04 × strength, glTF's
// KHR_materials_specular) from the light's key: the given key light, else the SH light's dominant direction. All in
// the model frame, so the light stays on the head when the camera turns. Linear light; the caller encodes.
#pragma once
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

// A camera `distance` mm from `target` turned by yaw (about +y, degrees; positive shows the face's left) then pitch
// (about +x; positive looks from above), size² pixels, the lens of view_camera.
Camera orbit_camera(int size, double yaw_deg, double pitch_deg, const Eigen::Vector3d& target, double distance = 1000);

}  // namespace bareskin
