// The rasterizer kernel (nvdiffrast/DRTK style): per pixel, the nearest triangle's id and its perspective-correct
// barycentrics; everything else (attributes, textures, shading, gradients) is built on those. Plain data in and out,
// no framework, so the Torch ops and a CUDA version share it.
//
// Input per vertex: pixel x, y (row 0 at the top) and the depth w along the view axis (> 0). A pixel's sample is its
// centre. Screen-space barycentrics λ come from edge functions; the perspective-correct ones are
// b_k = (λ_k / w_k) / Σ_j (λ_j / w_j), and the depth 1 / Σ_j (λ_j / w_j) is what the depth test compares (nearer wins;
// equal depths: the lower triangle id). Orthographic inputs simply use w = 1 and put the depth in `z`.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/mesh.h"
#include "render/camera.h"
#include "render/raster_kernel.h"

namespace bareskin {

struct RasterOutput {
  int width = 0, height = 0;
  std::vector<int32_t> triangle;  // per pixel, row-major: the triangle id, or -1 for background
  std::vector<float> bary;        // per pixel: b1, b2 (b0 = 1 - b1 - b2), perspective-correct
  std::vector<float> depth;       // per pixel: interpolated depth (+inf for background)
  int64_t dropped_behind = 0;     // triangles dropped for a vertex behind the near plane
};

// Multi-threaded tiled CPU rasterizer: triangles are binned into 32x32-pixel tiles, tiles run in parallel, each with
// its own depth buffer. The result does not depend on the thread count. InvalidInput for NaN/Inf vertices or indices
// out of range.
RasterOutput rasterize(const RasterInput& input);

// The same result by a plain loop over triangles and pixels (the test oracle).
RasterOutput rasterize_reference(const RasterInput& input);

// Vertices of a mesh projected by a camera: #V x 3 (x, y, w) floats, ready for RasterInput. For a weak-perspective
// camera w = 1 and the depth goes to `z` (pass it as RasterInput::z); for a pinhole camera `z` is left empty.
std::vector<float> project_vertices(const Eigen::MatrixX3d& V, const Camera& camera, std::vector<float>& z);

// A mesh seen by a camera: projection (project_vertices) and rasterization in one call.
RasterOutput rasterize_mesh(const Mesh& mesh, const Camera& camera, bool cull_back_faces = false);

// Rasterization in UV space at size x size: per texel, the triangle (face index) covering its centre and the
// barycentrics of that point (row 0 = v = 1). Uses the per-corner UVs (seams kept).
RasterOutput rasterize_uv(const Mesh& mesh, int size);

// For functions that take an optional UV raster (so that callers share one): `given` when not null (it must be size x
// size), otherwise rasterize_uv(mesh, size) made into `own`.
const RasterOutput& given_or_own_uv(const RasterOutput* given, const Mesh& mesh, int size, RasterOutput& own);

// Interpolates a per-vertex attribute (#V x C, row-major floats) at every covered pixel: out is W x H x C, zero
// where no triangle covers.
std::vector<float> interpolate(const RasterOutput& raster, const int32_t* triangles, const float* attribute, int channels);

}  // namespace bareskin
