// Texture-aware registration refinement (`scan register --texture-refine N`, docs/pipeline.md). After NICP the
// registered surface lies on the scan to < 0.001 mm, but points may slide along it: geometry does not say where on a
// smooth cheek a template point belongs; the scan's texture does. One round:
//   1. the scan's diffuse is transferred into the template UV through the current registration (render's UV raster of
//      the template, each texel's point on the registered surface, the closest scan point, the scan's atlas there);
//   2. it and a reference diffuse in the template UV (e.g. the mean of other scans' first-pass transfers) are reduced
//      to their structure, so that skin tone and shading drop out: log-luminance minus its local mean, over its local
//      standard deviation;
//   3. a dense flow d in UV, coarse to fine (pyramidal Lucas-Kanade on the reference's gradients, regularised by
//      confidence-weighted smoothing), takes the subject's structure onto the reference's: T(u + d(u)) ~ R(u);
//   4. so template UV u belongs where the registration now puts u + d(u): each confident template vertex gets that
//      point (the registered triangle under u + d, by its barycentrics, then projected onto the scan) as a soft
//      correspondence for a few NICP iterations.
// Geometry side only (no Torch, no OpenCV): small loops over float planes.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "render/rasterize.h"
#include "template/surface.h"

namespace bareskin {

struct TextureRefineOptions {
  int iterations = 0;           // rounds of transfer, flow and NICP (0: off)
  int resolution = 256;         // UV working size (texels per side, power of two)
  int levels = 4;               // pyramid levels of the flow
  double structure_sigma = 6;   // texels: the local mean / deviation taken out of log-luminance (at `resolution`)
  double structure_floor = 0.3; // its deviation's floor (log units): plain skin stays flat
  double confidence_quantile = 0.8;  // confidence 1/2 at this quantile (over the face) of the reference's structure
  double window = 3;            // texels: Lucas-Kanade's window (Gaussian sigma) at every level
  double smoothing = 8;         // texels: the flow's confidence-weighted smoothing (the regulariser) at every level
  int nicp_iterations = 3;      // NICP iterations per round, at `stiffness`
  double weight = 8;            // texture correspondences against the closest-point term (per node, on average)
  double data_weight = 0.3;     // the closest-point term's weight during refinement (it resists tangential moves)
  double stiffness = 0.4;       // NICP stiffness during refinement (stiffer than the schedule's end: slides are smooth)
  double min_confidence = 0.5;  // vertices whose flow confidence is lower get no texture correspondence
  double max_move_mm = 5;       // larger moves are treated as mismatches
  // Texture landmarks (texture_landmarks.h): rounds of finding the brows, eyes and lips in the texture and the nose in
  // the shape, and running NICP again from them with the hand-placed landmarks' weights (0: off), and the flows' UV size.
  // Their flow's sizes, in texels at 512 (scaled with landmark_resolution): finer than the refinement's, since only
  // the features count.
  int landmark_rounds = 0;
  int landmark_resolution = 512;
  double landmark_structure_sigma = 8, landmark_window = 3, landmark_smoothing = 6;
  // Shape points: in each round, about this many template vertices spread evenly over the face are placed by the same
  // curvature flow as the nose and held like landmarks, each with shape_point_weight times a landmark's weight. They
  // hold the lower face and cheeks, which no landmark marks (0: off; bench/BENCHMARKS.md, "Shape points").
  int shape_points = 2000;
  double shape_point_weight = 0.01;
  void check() const;           // InvalidInput when out of range
};

// A plane of floats, size x size, row 0 = v 1 (the UV raster's layout).
struct Plane {
  int size = 0;
  std::vector<float> v;
  float& at(int x, int y) { return v[size_t(y) * size_t(size) + size_t(x)]; }
  float at(int x, int y) const { return v[size_t(y) * size_t(size) + size_t(x)]; }
};

// The scan's linear diffuse seen through a registration: per texel of `raster` (rasterize_uv of the template mesh),
// the point of the registered surface `V` (template topology) there, its closest scan point and the scan's atlas UV
// there, sampled bilinearly. `valid` gets 1 where a texel was filled (layout covered, scan found, not black): a
// subset of layout_mask(raster).
Image transfer_diffuse(const RasterOutput& raster, const Mesh& template_mesh, const Eigen::MatrixX3d& V,
                       const Mesh& scan, const SurfaceLocator& scan_locator, const Image& scan_diffuse,
                       std::vector<uint8_t>& valid);

// Texels of a UV raster (rasterize_uv) that the layout covers: 1, else 0.
std::vector<uint8_t> layout_mask(const RasterOutput& raster);

// An image resampled to size x size (box filter when size divides it, else bilinear), linear colour.
Image resample_square(const Image& image, int size);

// What a structure image is made of: log-luminance (brows, eyes, nostrils, freckles), or redness, log(R / G), which
// shows lips against skin even where their luminance hardly differs (darker skin).
enum class TextureChannel { Luminance, Redness };

// The structure of a colour texture: the channel minus its local (Gaussian, `sigma` texels) mean, over its local
// standard deviation, over the valid texels (0 elsewhere). A multiplicative skin tone and slow shading drop out.
Plane texture_structure(const Image& linear, const std::vector<uint8_t>& valid, double sigma, double floor,
                        TextureChannel channel = TextureChannel::Luminance);

// The same for any plane of values: smoothed a texel, minus its local mean, over its local deviation (with `floor`),
// over the texels where `mask` is 1 (0 elsewhere).
Plane plane_structure(const Plane& values, const Plane& mask, double sigma, double floor);

// Displacement field (texels, x right, y down) with moving(u + d) ~ fixed(u), and a confidence in [0, 1] per texel:
// lambda / (lambda + kappa), lambda the smaller eigenvalue of the windowed structure tensor of `fixed` (the reference:
// its features are the ones every face shares), kappa its confidence_quantile over the mask. Coarse to fine, three
// warps per level, each update at most a texel, then d smoothed with the confidence as weight (the regulariser).
// `mask`: texels where both images are defined.
struct UvFlow {
  Plane dx, dy, confidence;
  // Bilinear at template uv (origin bottom-left).
  Eigen::Vector2f at(const Eigen::Vector2d& uv, float* confidence_out) const;
};
UvFlow uv_flow(const Plane& moving, const Plane& fixed, const std::vector<uint8_t>& mask, const TextureRefineOptions& o);

// Per vertex of `mesh`: its row in mesh.UV (-1: on no face).
std::vector<int> vertex_uv_rows(const Mesh& mesh);

// Where the flow takes template vertex v: the registered surface V (template topology) at v's UV moved by the flow,
// projected onto the scan; false when v has no UV (uv_rows: vertex_uv_rows), the flow's confidence there is below
// o.min_confidence, no template triangle holds the moved UV, or the point moved more than o.max_move_mm.
struct FlowTarget {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double confidence = 0, move_mm = 0;
};
bool flow_target(const Mesh& mesh, const Eigen::MatrixX3d& V, const RasterOutput& raster, const UvFlow& flow,
                 const SurfaceLocator& scan_locator, const std::vector<int>& uv_rows, int v,
                 const TextureRefineOptions& o, FlowTarget& out);

// Per template vertex with enough confidence: the registered surface's point at its UV moved by the flow, projected
// onto the scan, with the flow's confidence.
struct TextureTargets {
  std::vector<int> vertex;
  std::vector<Eigen::Vector3d> point;
  std::vector<double> confidence;
  double median_move_mm = 0;  // over the vertices kept
};
TextureTargets texture_targets(const Mesh& template_mesh, const Eigen::MatrixX3d& V, const RasterOutput& raster,
                               const UvFlow& flow, const SurfaceLocator& scan_locator, const TextureRefineOptions& o);

}  // namespace bareskin
