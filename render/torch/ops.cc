#include "render/torch/ops.h"

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <string>

#include "core/error.h"
#include "render/rasterize.h"
#include "render/sh.h"

#ifdef BARESKIN_TORCH_CUDA
#include <c10/cuda/CUDAGuard.h>
#include <c10/cuda/CUDAStream.h>

#include "render/rasterize_cuda.h"
#endif

namespace bareskin::render_torch {
namespace {

// Shapes, devices and sizes: known on the host, checked on every call without touching the device.
void require(bool ok, const std::string& what) {
  if (!ok) throw InvalidInput("render_torch", what, "fix the tensors passed to the render op");
}

std::atomic<bool>& device_checks_flag() {
  static std::atomic<bool> flag{[] {
    const char* env = std::getenv("BARESKIN_RENDER_CHECKS");
    return env && std::string(env) == "1";
  }()};
  return flag;
}

// Values (NaN positions, triangle indices out of range) of CUDA tensors: reading them back waits for the device, so
// only under the debug switch. Without it the kernel drops such triangles on the device (raster_kernel.h: setup).
// CPU tensors are checked by the CPU rasterizer itself (InvalidInput), at no device cost.
void check_values_on_host(const torch::Tensor& p, const torch::Tensor& t) {
  require(torch::isfinite(p).all().item<bool>(), "pos holds NaN or Inf");
  require(t.numel() == 0 || (t.min().item<int32_t>() >= 0 && t.max().item<int32_t>() < p.size(1)),
          "a triangle index is out of range");
}

// The kernel's parameters for frame 0 of p ([B, V, 3] float, contiguous) and t ([F, 3] int32, contiguous).
RasterInput raster_input(const torch::Tensor& p, const torch::Tensor& t, int64_t height, int64_t width, bool cull) {
  RasterInput in;
  in.xyw = p.data_ptr<float>();
  in.triangles = t.data_ptr<int32_t>();
  in.vertex_count = p.size(1);
  in.triangle_count = t.size(0);
  in.width = int(width);
  in.height = int(height);
  in.cull_back_faces = cull;
  return in;
}

// The CUDA rasterizer on CUDA tensors (p float, t int32, both checked), on the current stream.
Raster rasterize_gpu(const torch::Tensor& p, const torch::Tensor& t, int64_t height, int64_t width, bool cull) {
#ifdef BARESKIN_TORCH_CUDA
  const c10::cuda::CUDAGuard guard(p.device());
  const int64_t B = p.size(0);
  const auto on = torch::TensorOptions().device(p.device());
  const torch::Tensor triangle = torch::empty({B, height, width}, on.dtype(torch::kInt));
  const torch::Tensor bary = torch::empty({B, height, width, 2}, on.dtype(torch::kFloat));
  const torch::Tensor depth = torch::empty({B, height, width}, on.dtype(torch::kFloat));
  const torch::Tensor keys = torch::empty({B, height, width}, on.dtype(torch::kLong));
  const RasterInput in = raster_input(p, t, height, width, cull);
  RasterCudaOutput out;
  out.triangle = triangle.data_ptr<int32_t>();
  out.bary = bary.data_ptr<float>();
  out.depth = depth.data_ptr<float>();
  out.keys = reinterpret_cast<uint64_t*>(keys.data_ptr<int64_t>());
  rasterize_cuda(in, B, out, c10::cuda::getCurrentCUDAStream().stream());
  return {triangle.to(torch::kLong), bary};
#else
  require(false, "this build has no CUDA rasterizer: configure with nvcc found and a CUDA LibTorch, or pass CPU tensors");
  return {};
#endif
}

}  // namespace

void set_device_checks(bool on) { device_checks_flag() = on; }
bool device_checks() { return device_checks_flag(); }

bool cuda_rasterizer_built() {
#ifdef BARESKIN_TORCH_CUDA
  return true;
#else
  return false;
#endif
}

Raster rasterize(const torch::Tensor& pos, const torch::Tensor& tri, int64_t height, int64_t width, bool cull) {
  require(pos.dim() == 3 && pos.size(2) == 3, "pos must be [B, V, 3]");
  require(tri.dim() == 2 && tri.size(1) == 3, "tri must be [F, 3]");
  require(height > 0 && width > 0 && height * width <= (int64_t(1) << 28), "the image size must be 1 to 16384 pixels a side");
  require(tri.device() == pos.device(), "pos and tri must be on the same device");
  const torch::Tensor p = pos.detach().to(torch::kFloat).contiguous();
  const torch::Tensor t = tri.to(torch::kInt).contiguous();
  if (p.is_cuda()) {
    if (device_checks()) check_values_on_host(p, t);
    Raster r = rasterize_gpu(p, t, height, width, cull);
    r.bary = r.bary.to(pos.dtype());
    return r;
  }
  require(p.is_cpu(), "pos must be a CPU or CUDA tensor");
  const int64_t B = p.size(0);
  Raster out{torch::full({B, height, width}, -1, torch::kLong), torch::zeros({B, height, width, 2}, torch::kFloat)};
  for (int64_t b = 0; b < B; ++b) {
    const RasterInput in = raster_input(p.narrow(0, b, 1), t, height, width, cull);
    RasterOutput r = bareskin::rasterize(in);  // InvalidInput for NaN positions or indices out of range
    out.triangle[b].copy_(torch::from_blob(r.triangle.data(), {height, width}, torch::kInt).to(torch::kLong));
    out.bary[b].copy_(torch::from_blob(r.bary.data(), {height, width, 2}, torch::kFloat));
  }
  out.bary = out.bary.to(pos.dtype());
  return out;
}

torch::Tensor interpolate(const torch::Tensor& attr, const torch::Tensor& pos, const torch::Tensor& tri, const Raster& r) {
  require(attr.dim() == 3 && attr.size(0) == pos.size(0) && attr.size(1) == pos.size(1), "attr must be [B, V, C]");
  const int64_t B = pos.size(0), V = pos.size(1), H = r.triangle.size(1), W = r.triangle.size(2), C = attr.size(2);
  const torch::Tensor flat = r.triangle.reshape({-1});
  const torch::Tensor covered = (flat >= 0).nonzero().squeeze(1);  // pixel indices in [0, B*H*W)
  torch::Tensor out = torch::zeros({B * H * W, C}, attr.options());
  if (covered.numel() == 0) return out.reshape({B, H, W, C});
  const torch::Tensor face = flat.index_select(0, covered);
  const torch::Tensor batch = torch::div(covered, H * W, "floor");
  const torch::Tensor pixel = covered - batch * (H * W);
  const torch::Tensor corners = tri.to(torch::kLong).index_select(0, face) + (batch * V).unsqueeze(1);  // [N, 3]
  const torch::Tensor P = pos.reshape({B * V, 3}).index_select(0, corners.reshape({-1})).reshape({-1, 3, 3});
  const torch::Tensor cx = torch::remainder(pixel, W).to(pos.dtype()) + 0.5, cy = torch::div(pixel, W, "floor").to(pos.dtype()) + 0.5;
  // Corner k's x, y, w as [N] tensors, split with unbind (one backward each, not a full-size select per use).
  const std::vector<torch::Tensor> corner = P.unbind(1);
  std::vector<torch::Tensor> X, Y, w;
  for (const torch::Tensor& c : corner) {
    const std::vector<torch::Tensor> xyw = c.unbind(1);
    X.push_back(xyw[0]);
    Y.push_back(xyw[1]);
    w.push_back(xyw[2]);
  }
  const torch::Tensor area = (X[1] - X[0]) * (Y[2] - Y[0]) - (Y[1] - Y[0]) * (X[2] - X[0]);
  std::vector<torch::Tensor> lw;  // l_k / w_k with l_k the screen-space barycentric of corner k
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    const torch::Tensor l = ((X[a] - cx) * (Y[b] - cy) - (Y[a] - cy) * (X[b] - cx)) / area;
    lw.push_back(l / w[k]);
  }
  const torch::Tensor q = lw[0] + lw[1] + lw[2];
  const torch::Tensor A = attr.reshape({B * V, C}).index_select(0, corners.reshape({-1})).reshape({-1, 3, C});
  // Σ_k b_k A_k as one batched product [N, 1, 3] x [N, 3, C] (faster forward and backward than broadcast + sum).
  const torch::Tensor weights = torch::stack({lw[0], lw[1], lw[2]}, 1) / q.unsqueeze(1);
  const torch::Tensor value = torch::bmm(weights.unsqueeze(1), A).squeeze(1);
  out = out.index_copy(0, covered, value);
  return out.reshape({B, H, W, C});
}

torch::Tensor sh_shade(const torch::Tensor& albedo, const torch::Tensor& normal, const torch::Tensor& gamma) {
  require(albedo.dim() == 4 && albedo.size(3) == 3 && normal.sizes() == albedo.sizes(), "albedo and normal must be [B, H, W, 3]");
  require(gamma.dim() == 2 && gamma.size(0) == albedo.size(0) && gamma.size(1) == 27, "gamma must be [B, 27]");
  const auto [k0, k1, k2] = sh_scales();  // render/sh.h's basis
  const torch::Tensor n = normal / normal.norm(2, -1, true).clamp_min(1e-12);
  const std::vector<torch::Tensor> xyz = n.unbind(3);  // one backward (a stack) instead of three full-size selects
  const torch::Tensor &x = xyz[0], &y = xyz[1], &z = xyz[2];
  const torch::Tensor Y = torch::stack({torch::full_like(x, k0), -k1 * y, k1 * z, -k1 * x, k2 * x * y, -k2 * y * z,
                                        0.5 * k2 / std::sqrt(3.0) * (3 * z * z - 1), -k2 * x * z, 0.5 * k2 * (x * x - y * y)},
                                       3);  // [B, H, W, 9]
  // Irradiance per channel: Y · γ_c, as one batched matrix product [B, HW, 9] x [B, 9, 3].
  const int64_t B = albedo.size(0), H = albedo.size(1), W = albedo.size(2);
  const torch::Tensor g = gamma.to(albedo.dtype()).reshape({B, 3, 9}).transpose(1, 2);  // channel-major γ
  const torch::Tensor irradiance = torch::bmm(Y.reshape({B, H * W, 9}), g).reshape({B, H, W, 3});
  return albedo * irradiance;
}

torch::Tensor texture(const torch::Tensor& tex, const torch::Tensor& uv) {
  require(tex.dim() == 4 && uv.dim() == 4 && uv.size(3) == 2 && tex.size(0) == uv.size(0), "texture [B,C,Ht,Wt], uv [B,H,W,2]");
  // grid_sample's (-1, -1) is the top-left corner; v is up in UVs.
  const torch::Tensor grid = torch::stack({2 * uv.select(3, 0) - 1, 1 - 2 * uv.select(3, 1)}, 3);
  namespace F = torch::nn::functional;
  const torch::Tensor s = F::grid_sample(tex, grid, F::GridSampleFuncOptions().mode(torch::kBilinear).padding_mode(torch::kBorder).align_corners(false));
  return s.permute({0, 2, 3, 1});
}

}  // namespace bareskin::render_torch
