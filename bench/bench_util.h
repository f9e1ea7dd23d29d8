// Timing and geometry helpers shared by the Torch-side benchmarks (render_torch_bench, training_bench, losses_bench,
// detect_bench): one way to time a call on the CPU or on CUDA, medians, and differentiable vertex normals.
#pragma once
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <vector>

#ifdef BARESKIN_TORCH_CUDA
#include <c10/cuda/CUDAStream.h>
#include <cuda_runtime.h>
#endif

namespace bareskin::bench {

// Milliseconds of one call of `work`: CUDA events on the current stream where this build has CUDA, otherwise the
// steady clock (after synchronising the device when `cuda`).
inline double time_ms(const std::function<void()>& work, bool cuda) {
#ifdef BARESKIN_TORCH_CUDA
  if (cuda) {
    cudaEvent_t start, stop;
    cudaEventCreate(&start);
    cudaEventCreate(&stop);
    const cudaStream_t stream = c10::cuda::getCurrentCUDAStream().stream();
    cudaEventRecord(start, stream);
    work();
    cudaEventRecord(stop, stream);
    cudaEventSynchronize(stop);
    float ms = 0;
    cudaEventElapsedTime(&ms, start, stop);
    cudaEventDestroy(start);
    cudaEventDestroy(stop);
    return ms;
  }
#endif
  if (cuda) torch::cuda::synchronize();
  const auto t0 = std::chrono::steady_clock::now();
  work();
  if (cuda) torch::cuda::synchronize();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

inline double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Median milliseconds of `repeats` calls of `work` after `warmup` untimed ones.
inline double median_ms(const std::function<void()>& work, int repeats, bool cuda, int warmup = 1) {
  for (int i = 0; i < warmup; ++i) work();
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) ms.push_back(time_ms(work, cuda));
  return median(ms);
}

// Per-vertex normals (area-weighted sum of face normals, not normalised) of [B, V, 3] positions; differentiable.
inline torch::Tensor vertex_normals(const torch::Tensor& pos, const torch::Tensor& tri) {
  const torch::Tensor a = pos.index_select(1, tri.select(1, 0)), b = pos.index_select(1, tri.select(1, 1)),
                      c = pos.index_select(1, tri.select(1, 2));
  const torch::Tensor fn = torch::cross(b - a, c - a, 2);
  torch::Tensor n = torch::zeros_like(pos);
  for (int k = 0; k < 3; ++k) n = n.index_add(1, tri.select(1, k), fn);
  return n;
}

}  // namespace bareskin::bench
