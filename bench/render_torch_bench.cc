// Speed of the differentiable render, the work BareSkinNet's training does per step: batch 4 of the template
// (65k vertices) with per-frame vertex offsets, projected by the Deep3DFaceRecon camera, vertex normals, rasterize,
// interpolate albedo and normals, SH shading (27 coefficients), an L2 loss to a target, and backward to the vertex
// positions, the albedo and the lighting. Medians over repeats after a warm-up, at 256² and 1024², on the CPU and on
// CUDA where present; CUDA is timed with CUDA events on the current stream.
//   render_torch_bench TEMPLATE_DIR [REPEATS]
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <malloc.h>
#include <string>
#include <thread>
#include <vector>

#include "core/safetensors.h"
#include "bench/bench_util.h"
#include "render/torch/ops.h"

// One namespace per program: bench/torch_bench.cc runs this main under the name `render_torch_bench` (one binary, one unity
// translation unit for every Torch bench).
namespace bareskin_bench_render_torch {


using namespace bareskin;
using bench::median;
using bench::time_ms;
using bench::vertex_normals;

namespace {

}  // namespace

int main(int argc, char** argv) {
  mallopt(M_MMAP_MAX, 0);  // as the CLI: page faults are expensive on our VMs
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  torch::set_num_threads(int(std::thread::hardware_concurrency()));  // LibTorch counts physical cores only
  if (argc < 2) {
    std::fprintf(stderr, "usage: render_torch_bench TEMPLATE_DIR [REPEATS]\n");
    return 2;
  }
  const int repeats = argc > 2 ? std::atoi(argv[2]) : 10;
  const SafeTensors face = SafeTensors::open(std::string(argv[1]) + "/face.safetensors");
  std::vector<float> V = face.tensor("vertices", DType::F32, {-1, 3}).to_vector<float>();
  std::vector<int32_t> F = face.tensor("triangles", DType::I32, {-1, 3}).to_vector<int32_t>();
  const int64_t nv = int64_t(V.size() / 3), nf = int64_t(F.size() / 3);
  const torch::Tensor verts = torch::from_blob(V.data(), {nv, 3}).clone();
  const torch::Tensor tri_cpu = torch::from_blob(F.data(), {nf, 3}, torch::kInt).to(torch::kLong);
  const int B = 4;
  std::printf("differentiable render: template %lld vertices, %lld triangles, batch %d, %d CPU threads\n", (long long)nv,
              (long long)nf, B, torch::get_num_threads());
  std::printf("%-6s %-6s %12s %12s %12s %10s\n", "device", "size", "forward ms", "backward ms", "total ms", "px/frame");
  std::vector<torch::Device> devices = {torch::kCPU};
  if (render_torch::cuda_rasterizer_built() && torch::cuda::is_available()) devices.emplace_back(torch::kCUDA);
  for (const torch::Device device : devices) {
    const bool cuda = device.is_cuda();
    torch::manual_seed(1);
    const torch::Tensor tri = tri_cpu.to(device);
    const torch::Tensor centre = verts.mean(0);
    const torch::Tensor base = (verts - centre).unsqueeze(0).expand({B, nv, 3}).to(device);
    const torch::Tensor offsets = (torch::randn({B, nv, 3}) * 0.5).to(device).requires_grad_(true);
    const torch::Tensor albedo = (torch::rand({B, nv, 3}) * 0.5 + 0.3).to(device).requires_grad_(true);
    torch::Tensor gamma0 = torch::zeros({B, 27});
    gamma0.select(1, 0).fill_(0.8);
    gamma0.select(1, 9).fill_(0.8);
    gamma0.select(1, 18).fill_(0.8);
    const torch::Tensor gamma = gamma0.to(device).requires_grad_(true);
    for (int size : {256, 1024}) {
      const double f = 1015.0 * size / 224, c = size / 2.0;
      const torch::Tensor target = torch::rand({B, size, size, 3}).to(device);
      torch::Tensor loss;
      torch::Tensor triangle;
      const auto forward = [&] {
        const torch::Tensor world = base + offsets;
        const torch::Tensor depth = 1000 - world.select(2, 2);  // the camera 1 m in front, looking down −z
        const torch::Tensor pos = torch::stack({c + f * world.select(2, 0) / depth, c - f * world.select(2, 1) / depth, depth}, 2);
        const render_torch::Raster r = render_torch::rasterize(pos, tri, size, size, true);
        // One interpolation for both attributes: the barycentrics (and their gradients) are computed once.
        const torch::Tensor both = render_torch::interpolate(torch::cat({albedo, vertex_normals(world, tri)}, 2), pos, tri, r);
        const torch::Tensor image = render_torch::sh_shade(both.narrow(3, 0, 3), both.narrow(3, 3, 3), gamma);
        loss = (image - target).pow(2).mean();
        triangle = r.triangle;
      };
      const auto backward = [&] { loss.backward(); };
      for (int i = 0; i < 2; ++i) {
        forward();
        backward();
      }
      std::vector<double> fw, bw;
      for (int i = 0; i < repeats; ++i) {
        fw.push_back(time_ms(forward, cuda));
        bw.push_back(time_ms(backward, cuda));
      }
      const double fm = median(fw), bm = median(bw);
      const int64_t covered = (triangle >= 0).sum().item<int64_t>() / B;
      std::printf("%-6s %4d²  %12.2f %12.2f %12.2f %10lld\n", cuda ? "cuda" : "cpu", size, fm, bm, fm + bm, (long long)covered);
    }
  }
  return 0;
}

}  // namespace bareskin_bench_render_torch
