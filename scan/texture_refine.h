// Texture-aware registration refinement (`scan register --texture-refine N`, docs/registration.md). After NICP the
// registered surface matches the scan to < 0.001 mm, but points may slide along it: geometry does not say where on a
// smooth nose side a template point belongs; the scan's texture does. One round:
//   1. the scan's diffuse is transferred into the template UV through the current registration;
//   2. it and a reference diffuse in the template UV (a population mean, given by the user) are normalised so that skin
//      tone and shading drop out: log-luminance and log red/green chroma, minus their local mean, over their spread;
//   3. a dense flow d in UV (coarse to fine, Lucas-Kanade with confidence-weighted smoothing as the regulariser) takes
//      the subject's texture onto the reference: T(u + d(u)) ~ R(u);
//   4. so template UV u belongs where the registration now puts u + d(u): each confident template vertex gets that point
//      (on the registered surface, projected onto the scan) as a soft correspondence for a few more NICP iterations.
// Geometry side only (no Torch, no OpenCV): the UV raster, the flow and the targets are small loops over float images.
#pragma once
#include <Eigen/Core>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "template/surface.h"

namespace bareskin {

struct TextureRefineOptions {
  int iterations = 0;          // rounds of transfer, flow and NICP (0: off)
  int resolution = 256;        // UV working size (texels per side)
  double search_mm = 5;        // the largest slide looked for
  int nicp_iterations = 3;     // NICP iterations per round, at the last stiffness
  double weight = 2;           // texture correspondences against the closest-point term (per node, on average)
  double data_weight = 0.3;    // the closest-point term's weight during refinement (it resists tangential moves)
  double stiffness = 0.4;      // NICP stiffness during refinement (stiffer than the schedule's end: the slide is smooth)
  double min_confidence = 0.2; // vertices whose flow confidence is lower get no texture correspondence
  double max_flow_mm = 8;      // larger flows are treated as mismatches
  void check() const;          // InvalidInput when out of range
};

// The template's UV layout rasterised once: per texel (rows top first, uv origin bottom-left) the face whose UV
// triangle holds its centre (-1: none) and the barycentric weights there.
struct UvRaster {
  int size = 0;
  std::vector<int> face;
  std::vector<Eigen::Vector3f> barycentric;
  const Eigen::MatrixX3i* F = nullptr;  // the rasterised mesh's faces and UVs (kept by the caller)
  const Eigen::MatrixX2d* UV = nullptr;
  const Eigen::MatrixX3i* FUV = nullptr;
  // The face holding `uv` (searched from the texel under it and its neighbours) and its barycentric weights, clamped
  // inside the face; false when no face is near.
  bool locate(const Eigen::Vector2d& uv, int& face, Eigen::Vector3d& b) const;
};
UvRaster uv_texel_raster(const Mesh& mesh, int size);

// Millimetres of surface per unit of UV (median over the faces' first edges).
double mm_per_uv(const Mesh& mesh);

// The scan's linear diffuse sampled into the template UV through the template vertices `V` (on the scan): per texel of
// `raster`, its point on the registered surface, the closest scan point, the scan's UV there. Texels outside the layout
// are 0 and `valid` says which texels were filled.
Image transfer_diffuse(const UvRaster& raster, const Eigen::MatrixX3d& V, const Mesh& scan, const SurfaceLocator& scan_locator,
                       const Image& scan_diffuse, std::vector<uint8_t>& valid);

// An image resampled to size x size (box filter when size divides it, else bilinear), linear colour.
Image resample_square(const Image& image, int size);

// Two normalised channels (log-luminance, log red/green), each minus its local mean (Gaussian, `sigma` texels) and
// divided by its spread over the valid texels: skin tone (a multiplicative factor) and slow shading drop out.
struct TextureStructure {
  int size = 0;
  std::vector<float> channel[2];
  std::vector<float> mask;  // 1 where valid
};
TextureStructure normalise_texture(const Image& linear, const std::vector<uint8_t>& valid, double sigma = 8);

// Displacement field from `moving` to `fixed` (moving(u + d) ~ fixed(u)), in texels, and a confidence in [0, 1] per
// texel. Block matching: at anchors on a grid where the reference's patch has structure in both directions (its
// structure tensor's smaller eigenvalue in the top third), the subject's patch is searched within `radius` texels by
// normalised cross-correlation (contrast-invariant: a pale brow matches a dark one), the peak refined to sub-texel
// by parabolas and kept when it is high (>= 0.6) and sharp in both axes; the kept displacements are spread by
// normalised convolution (the regulariser), the confidence being the matched anchors' density.
struct UvFlow {
  int size = 0;
  std::vector<Eigen::Vector2f> d;
  std::vector<float> confidence;
  Eigen::Vector2f at(const Eigen::Vector2d& uv, float* confidence_out) const;  // bilinear, uv origin bottom-left
};
UvFlow uv_flow(const TextureStructure& moving, const TextureStructure& fixed, int radius);

// Per template vertex with enough confidence: the point of the registered surface at its UV moved by the flow,
// projected onto the scan. `mm_per_texel` converts the flow length for max_flow_mm.
struct TextureTargets {
  std::vector<int> vertex;
  std::vector<Eigen::Vector3d> point;
  std::vector<double> confidence;
  double median_flow_mm = 0;  // over the vertices kept
};
TextureTargets texture_targets(const Mesh& template_mesh, const Eigen::MatrixX3d& V, const UvRaster& raster,
                               const UvFlow& flow, const SurfaceLocator& scan_locator, const TextureRefineOptions& options);

}  // namespace bareskin
