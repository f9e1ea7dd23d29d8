// The CUDA rasterizer: the same ids, barycentrics and depths as rasterize() (render/raster_kernel.h), for B frames
// sharing one triangle list, every pointer in device memory. Built where nvcc is found (BARESKIN_WITH_CUDA); the
// Torch ops call it for CUDA tensors.
//
// Two passes on the caller's stream: one warp per triangle takes an atomic minimum of (depth, id) keys over the
// pixels it covers, then one thread per pixel recomputes the winner's barycentrics. Nothing is checked on the host:
// the caller validates positions (finite) and sizes; triangles with an index out of range are dropped, never read.
#pragma once
#include <cstdint>

#include "render/raster_kernel.h"

namespace bareskin {

struct RasterCudaOutput {
  int32_t* triangle = nullptr;         // B x H x W: triangle id or -1
  float* bary = nullptr;               // B x H x W x 2: b1, b2
  float* depth = nullptr;              // B x H x W: depth, +inf at the background
  uint64_t* keys = nullptr;            // B x H x W scratch
  unsigned long long* dropped_behind = nullptr;  // optional: one counter, incremented per triangle behind the camera
};

// Frame b reads in.xyw + b·V·3 (and in.z + b·V when in.z is set) and writes at b·H·W. `stream` is a cudaStream_t
// (nullptr: the default stream). Throws std::runtime_error when a launch fails.
void rasterize_cuda(const RasterInput& in, int64_t batch, const RasterCudaOutput& out, void* stream);

}  // namespace bareskin
