// The pictures of one `texgen faces` sample from one rasterization (docs/datasets.md): a posed face seen by a camera,
// shaded several ways (with and without makeup, with and without light), its masks, the background behind it and
// painted 2D occluders in front. Linear light throughout; the caller encodes sRGB.
#pragma once
#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "detect/align.h"
#include "render/camera.h"
#include "render/rasterize.h"
#include "texgen/face_world.h"
#include "uvtools/mask.h"

namespace bareskin::texgen {

// Per pixel of one rasterization: what the shadings need.
struct Surface {
  Camera camera;
  RasterOutput raster;
  std::vector<float> uv, normal, position;  // interpolated: 2, 3 (world, unit after normalising), 3 channels
  bool covered(size_t pixel) const { return raster.triangle[pixel] >= 0; }
};

// `mesh` posed (V, F, UV, FUV); vertex normals computed here. Back faces are culled.
Surface rasterize_face(const Mesh& mesh, const Camera& camera);

// A face's maps in the template UV: diffuse linear RGB; roughness, specular 1 channel (any size, 1x1 for constants).
struct SurfaceMaps {
  const Image* diffuse = nullptr;
  const Image* roughness = nullptr;
  const Image* specular = nullptr;
};

// The lit face, colour = albedo · (Y(n) · γ) + specular key light (Blinn-Phong: exponent 2/r⁴ − 2 from the perceptual
// roughness r, normalised (p + 8)/8π, scaled by the specular map), written into `out` (3 channels, linear) where the
// face covers; other pixels are left as they are.
void shade(const Surface& s, const SurfaceMaps& maps, const Light& light, Image& out);

// The map sampled at every covered pixel (bilinear), 0 elsewhere: bare.png is shade-less albedo.
Image sample_map(const Surface& s, const Image& map);

// A background (linear RGB, size²): value noise, a gradient, or a crop of one of `photos` (linear RGB). `kind` says
// which ("noise", "gradient", "photo:<name>").
struct BackgroundPhoto {
  std::string name;
  Image linear;
};
Image make_background(int size, const std::vector<BackgroundPhoto>& photos, Rng& rng, std::string* kind);

// Photos Debian ships with python3-skimage that hold no face (brick, grass, gravel, coffee, ...), read from `folder`
// when present (linear RGB); none otherwise.
std::vector<BackgroundPhoto> read_background_photos(const std::string& folder);

// The rest of the head behind the face mesh, painted into the background from the 68 landmarks (pixels): hair over
// the crown and the sides, ears, a neck in the shade of the chin, in the subject's skin tone (linear, lit) and a hair
// colour. The mesh covers the face itself; this is context for the detector (a face mask on a texture reads as no
// face), never part of the face or skin masks.
void paint_head(Image& background, const std::vector<Eigen::Vector2d>& landmarks, const Eigen::Vector3f& skin,
                const Eigen::Vector3f& hair, Rng& rng);

// Occluders (hair fringe, glasses, hand, hat) drawn from uvtools/mask.h around the landmarks (pixels), with the
// colours they are painted in.
struct Occluders {
  LabelImage labels;  // 0 where nothing covers
  std::vector<std::string> kinds;
  Eigen::Vector3f hair, frame, hand, hat;  // linear colours
  uint64_t texture_seed = 0;
  bool any() const { return !kinds.empty(); }
};
Occluders draw_occluders(int size, const std::vector<Eigen::Vector2d>& landmarks, double probability, Rng& rng);
// The same occluders in another frame: labels resampled (nearest) through the similarity.
Occluders warp_occluders(const Occluders& o, const detect::Similarity& similarity, int size);
// Paints them over a linear RGB image (strands for hair, a soft shading for the hand).
void paint_occluders(const Occluders& o, Image& linear);

}  // namespace bareskin::texgen
