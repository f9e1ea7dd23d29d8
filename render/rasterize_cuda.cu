#include <cuda_runtime.h>

#include <stdexcept>
#include <string>

#include "render/rasterize_cuda.h"

namespace bareskin {
namespace {

constexpr int kLanes = 32;  // one warp per triangle
constexpr int kBlock = 256;

__global__ void cover_kernel(RasterInput in, uint64_t* keys, unsigned long long* dropped_behind) {
  const int64_t t = int64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  const int64_t f = t / kLanes;
  if (f >= in.triangle_count) return;
  const int64_t b = blockIdx.y;
  const float* xyw = in.xyw + b * in.vertex_count * 3;
  const float* z = in.z ? in.z + b * in.vertex_count : nullptr;
  unsigned long long* frame = reinterpret_cast<unsigned long long*>(keys + b * int64_t(in.width) * in.height);
  const int lane = int(t % kLanes);
  const raster::SetupResult r = raster::cover(in, xyw, z, f, lane, kLanes, [frame](int64_t i, uint64_t key) {
    atomicMin(frame + i, static_cast<unsigned long long>(key));
  });
  if (r == raster::kBehind && lane == 0 && dropped_behind) atomicAdd(dropped_behind, 1ull);
}

__global__ void resolve_kernel(RasterInput in, int64_t batch, const uint64_t* keys, int32_t* triangle, float* bary,
                               float* depth) {
  const int64_t pixels = int64_t(in.width) * in.height;
  const int64_t i = int64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i >= batch * pixels) return;
  const int64_t b = i / pixels, p = i % pixels;
  const float* xyw = in.xyw + b * in.vertex_count * 3;
  const float* z = in.z ? in.z + b * in.vertex_count : nullptr;
  raster::resolve(in, xyw, z, keys[i], int(p % in.width), int(p / in.width), triangle[i], bary + 2 * i, depth[i]);
}

void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw std::runtime_error(std::string("CUDA rasterizer: ") + what + ": " + cudaGetErrorString(e));
}

}  // namespace

void rasterize_cuda(const RasterInput& in, int64_t batch, const RasterCudaOutput& out, void* stream_ptr) {
  const cudaStream_t stream = static_cast<cudaStream_t>(stream_ptr);
  const int64_t pixels = batch * int64_t(in.width) * in.height;
  if (batch <= 0 || pixels <= 0) return;
  if (batch > 65535) throw std::runtime_error("CUDA rasterizer: at most 65535 frames a call");
  check(cudaMemsetAsync(out.keys, 0xff, size_t(pixels) * sizeof(uint64_t), stream), "clearing the depth keys");
  if (in.triangle_count > 0) {
    const dim3 grid(unsigned((in.triangle_count * kLanes + kBlock - 1) / kBlock), unsigned(batch));
    cover_kernel<<<grid, kBlock, 0, stream>>>(in, out.keys, out.dropped_behind);
    check(cudaGetLastError(), "cover pass");
  }
  resolve_kernel<<<unsigned((pixels + kBlock - 1) / kBlock), kBlock, 0, stream>>>(in, batch, out.keys, out.triangle,
                                                                                 out.bary, out.depth);
  check(cudaGetLastError(), "resolve pass");
}

}  // namespace bareskin
