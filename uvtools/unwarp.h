// `uvtools unwarp`: an image sampled into the mesh's UV through a camera, with visibility. Every UV texel's surface
// point (UV-space rasterization) is projected into the image; it counts as seen when it is in the frame and its depth
// matches the depth buffer of a rendering from the same camera (so occluded texels are not smeared with the
// occluder's colour). The image is sampled bilinearly in linear light; the confidence is the cosine between the
// surface normal and the direction to the camera (0 where unseen). The inverse, UV to image, is the renderer's texture
// lookup (render/shade.h).
#pragma once
#include "core/image.h"
#include "core/mesh.h"
#include "render/camera.h"

namespace bareskin {

struct RasterOutput;  // render/rasterize.h

struct UnwarpOptions {
  int size = 1024;              // UV map size
  double depth_tolerance = 1.0; // mm: a texel is seen when its depth is within this of the depth buffer
  // Optional 1-channel mask at the image's size (e.g. where a face covers a render): a texel whose bilinear sample of
  // it is below 1, i.e. that touches the mask's zeros, counts as unseen.
  const Image* inside = nullptr;
  // Optional: rasterize_uv(mesh, size), for callers that unwarp many times into one layout (the UV raster depends on
  // the UVs and faces only, not on the pose); nullptr: made here.
  const RasterOutput* uv_raster = nullptr;
  void check() const;  // InvalidInput when out of range
};

struct UnwarpResult {
  Image colour;       // size x size, linear RGB; 0 where unseen
  Image confidence;   // size x size, 1 channel: cos(view angle) where seen, 0 elsewhere
  int64_t seen = 0, in_layout = 0;  // texels seen / texels inside the UV layout
};

// `image` may be sRGB or linear (it is decoded); its size must be the camera's. InvalidInput otherwise, or for a mesh
// without UVs.
UnwarpResult unwarp(const Image& image, const Mesh& mesh, const Camera& camera, const UnwarpOptions& options = {});

}  // namespace bareskin
