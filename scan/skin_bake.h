// Bakes the procedural skin (scan/skin.h) into the four maps of a mesh's UV atlas: diffuse, tangent-space normal,
// roughness, specular. The atlas is rasterised a band of rows at a time and streamed to disk, so 16K maps need
// memory for one band, not for the image. The same code bakes a scan's maps (its own atlas) and the truth maps in the
// template UV (the template deformed by the subject's identity), which is what a perfect registration would produce.
#pragma once
#include <Eigen/Core>
#include <string>

#include "core/mesh.h"
#include "core/progress.h"
#include "scan/skin.h"
#include "scan/uv_maps.h"

namespace bareskin {

// A surface to bake: the mesh whose atlas the maps are laid out in (V in mm, F, UV/FUV, N), and for each of its
// vertices the template point and template UV where the skin model is evaluated (linear across each triangle).
struct SkinSurface {
  Mesh mesh;
  Eigen::MatrixX3d template_point;
  Eigen::MatrixX2d template_uv;
};

// The material and shading normal at a point of `surface` (face, barycentrics), as the bake computes them for a
// texel there with the given footprint (mm per texel). `normal` is tangent-space, unit, +z out of the surface.
struct SkinTexel {
  SkinMaterial material;
  Eigen::Vector3f normal;
};
class SkinBaker {
 public:
  SkinBaker(const SkinSurface& surface, const SkinModel& model);
  SkinTexel evaluate(int face, const Eigen::Vector3f& barycentric, float footprint) const;
  // The tangent frame the normal map is expressed in at that point: columns tangent, bitangent, normal (world space),
  // so world normal = frame * tangent-space normal.
  Eigen::Matrix3f frame(int face, const Eigen::Vector3f& barycentric) const;
  // mm of template surface per unit of atlas UV on this face (the footprint of one texel is this / resolution).
  float mm_per_uv(int face) const { return mm_per_uv_[size_t(face)]; }

  // Writes dir/{diffuse,normal,roughness,specular}<ext> atomically. Diffuse is sRGB in PNG/TIFF and linear in EXR;
  // the rest are data: normal as (n + 1) / 2 with +y up (OpenGL), roughness and specular as they are.
  void bake(const std::string& dir, const BakeOptions& options, const ProgressCallback& progress = {}) const;

 private:
  const SkinSurface& surface_;
  const SkinModel& model_;
  Eigen::MatrixX4d tangents_;
  std::vector<Eigen::Matrix3f> gradient_map_;  // template-space height gradient -> surface gradient, per face
  std::vector<float> mm_per_uv_;
};

}  // namespace bareskin
