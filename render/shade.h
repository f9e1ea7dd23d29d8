// A rendered frame of a textured mesh: one rasterization (render/rasterize.h), then the passes from it: colour =
// albedo × SH irradiance (render/sh.h, normals in the camera frame), albedo alone, depth, camera-frame normals and
// the coverage mask. Linear light throughout; the caller encodes for display.
#pragma once
#include <array>
#include <string>

#include "core/image.h"
#include "core/mesh.h"
#include "render/camera.h"

namespace bareskin {

struct ShadeOptions {
  const Image* texture = nullptr;               // diffuse albedo in the mesh's UV (linear); none: `albedo` below
  Eigen::Vector3f albedo = {0.6f, 0.6f, 0.6f};  // linear
  std::array<double, 27> gamma{};               // SH coefficients, channel-major (see sh.h)
  bool cull_back_faces = false;
  void check() const;  // InvalidInput for a negative or non-finite albedo or lighting
};

// Deep3DFaceRecon's ambient (0.8 on each channel's first coefficient) plus a soft key light from above and the front.
std::array<double, 27> default_lighting();
// `render --sh`: "default" (default_lighting), "none" (Deep3DFaceRecon's ambient alone) or a JSON file of 27 finite
// numbers, channel-major. InvalidInput naming the file otherwise.
std::array<double, 27> read_sh_lighting(const std::string& sh);

struct Frame {
  Image colour, albedo;  // linear RGB; background 0
  Image depth;           // 1 channel, mm along the view axis; background 0
  Image normal;          // camera-frame unit normals, (n + 1) / 2; background 0
  Image mask;            // 1 channel: 1 where a triangle covers
  int64_t dropped_behind = 0;
  // A W × H frame with every pass zero (the background), as the renderers start from.
  static Frame blank(int W, int H);
};

// InvalidInput when the mesh is empty, has NaN vertices, or a texture but no UVs.
Frame render_frame(const Mesh& mesh, const Camera& camera, const ShadeOptions& options);

// One pass of a frame ("colour", "albedo", "normal", "mask", "depth") as the image to write: depth normalised over
// the covered range (nearer brighter), colour and albedo sRGB-encoded, unless `exr` (the values as they are).
Image pass_image(const Frame& frame, const std::string& pass, bool exr);

}  // namespace bareskin
