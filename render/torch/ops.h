// Differentiable rendering ops in LibTorch on the rasterizer kernel (render/rasterize.h), in the nvdiffrast style:
// - rasterize: per pixel the nearest triangle and its barycentrics; visibility carries no gradient;
// - interpolate: vertex attributes at the pixels, with the barycentrics recomputed from the gathered vertex positions
//   by the same edge functions as the kernel, so gradients reach both the attributes and the positions (the pixels a
//   triangle covers are held fixed: no silhouette gradients, as nvdiffrast without antialiasing);
// - texture: bilinear lookups in a texture by interpolated UVs (grid_sample, border padding), origin bottom-left.
// - sh_shade: albedo × SH irradiance of the interpolated normals (render/sh.h's basis, 27 coefficients).
// Batches of B meshes sharing one triangle list; float or double; CPU tensors, or CUDA tensors where the build has the
// CUDA rasterizer (render/rasterize_cuda.h), which gives the CPU's ids and barycentrics to the bit.
#pragma once
#include <torch/torch.h>

namespace bareskin::render_torch {

struct Raster {
  torch::Tensor triangle;  // [B, H, W] int64: triangle id, or -1
  torch::Tensor bary;      // [B, H, W, 2]: b1, b2 (perspective-correct), no gradient
};

// pos: [B, V, 3] pixel x, pixel y (row 0 at the top) and depth w > 0; tri: [F, 3] integer. Throws InvalidInput
// (core/error.h) for wrong shapes or sizes; for NaN positions or indices out of range with CPU tensors. CUDA tensors
// are not read back (that would wait for the device on every call): the kernel drops such triangles, unless the debug
// switch (set_device_checks, or BARESKIN_RENDER_CHECKS=1 in the environment) checks them and throws.
Raster rasterize(const torch::Tensor& pos, const torch::Tensor& tri, int64_t height, int64_t width,
                 bool cull_back_faces = false);

// The debug switch above: value checks of CUDA inputs that synchronise with the device. Off by default.
void set_device_checks(bool on);
bool device_checks();

// Whether rasterize() takes CUDA tensors in this build.
bool cuda_rasterizer_built();

// attr: [B, V, C] → [B, H, W, C] (zero at background), differentiable in attr and pos.
torch::Tensor interpolate(const torch::Tensor& attr, const torch::Tensor& pos, const torch::Tensor& tri, const Raster& raster);

// albedo, normal: [B, H, W, 3] (normals need not be unit: they are normalised); gamma: [B, 27] channel-major (R's 9,
// G's 9, B's 9) → albedo × (Y(n) · γ_c), differentiable in all three. Without light, the albedo itself is the render.
torch::Tensor sh_shade(const torch::Tensor& albedo, const torch::Tensor& normal, const torch::Tensor& gamma);

// texture: [B, C, Ht, Wt]; uv: [B, H, W, 2] in [0, 1] with v up → [B, H, W, C].
torch::Tensor texture(const torch::Tensor& tex, const torch::Tensor& uv);

}  // namespace bareskin::render_torch
