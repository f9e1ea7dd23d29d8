// The rasterizer's per-triangle and per-pixel arithmetic, shared by the CPU rasterizer (rasterize.cc) and the CUDA one
// (rasterize_cuda.cu) so that both give the same ids, barycentrics and depths to the bit: both evaluate these
// functions in double, and the CUDA file is built without FMA contraction.
//
// The CUDA rasterizer resolves visibility with one 64-bit atomic minimum per pixel over `depth_key`: the depth's bits
// made order-preserving in the high word, the triangle id in the low word. The smallest key is the nearest triangle,
// and among equal depths the lowest id: the CPU rasterizer's rule. A second pass recomputes the winner's barycentrics.
#pragma once
#include <cmath>
#include <cstdint>
#include <cstring>

#if defined(__CUDACC__)
#define BARESKIN_HD __host__ __device__ inline
#else
#define BARESKIN_HD inline
#endif

namespace bareskin {

// The rasterizer's parameters: plain pointers (host memory for rasterize(), device memory for rasterize_cuda()).
struct RasterInput {
  const float* xyw = nullptr;  // #V x 3: pixel x, pixel y, depth w (> 0)
  const float* z = nullptr;    // optional #V: depth to test instead of w (orthographic); nullptr: w
  const int32_t* triangles = nullptr;  // #F x 3
  int64_t vertex_count = 0, triangle_count = 0;
  int width = 0, height = 0;
  bool cull_back_faces = false;  // drop triangles whose screen winding is clockwise (seen from behind)
  double near = 1e-3;            // triangles with a vertex at w <= near are dropped (behind the camera)
};

namespace raster {

// A triangle ready for pixel tests: corners in pixels, reciprocal depths, depths to test, the signed doubled area and
// the pixel bounding box (clamped to the image).
struct Setup {
  double x[3], y[3], inv_w[3], z[3], area;
  int x0, x1, y0, y1;
};

enum SetupResult : int { kLive = 0, kDropped = 1, kBehind = 2 };

BARESKIN_HD double min3(double a, double b, double c) { return a < b ? (a < c ? a : c) : (b < c ? b : c); }
BARESKIN_HD double max3(double a, double b, double c) { return a > b ? (a > c ? a : c) : (b > c ? b : c); }

// Set-up of triangle f of the frame whose vertices start at xyw (and z). kDropped when the triangle is degenerate,
// culled, off screen or has an index out of range; kBehind when a vertex is at or behind the near plane.
BARESKIN_HD SetupResult setup(const RasterInput& in, const float* xyw, const float* z, int64_t f, Setup& s) {
  for (int k = 0; k < 3; ++k) {
    const int64_t v = in.triangles[3 * f + k];
    if (v < 0 || v >= in.vertex_count) return kDropped;
    s.x[k] = xyw[3 * v];
    s.y[k] = xyw[3 * v + 1];
    const double w = xyw[3 * v + 2];
    if (!(w > in.near)) return kBehind;
    s.inv_w[k] = 1 / w;
    s.z[k] = z ? z[v] : w;
  }
  s.area = (s.x[1] - s.x[0]) * (s.y[2] - s.y[0]) - (s.y[1] - s.y[0]) * (s.x[2] - s.x[0]);
  if (!(s.area > 1e-12 || s.area < -1e-12)) return kDropped;
  // y is down on screen, so a counter-clockwise (front-facing) triangle has a negative area here.
  if (in.cull_back_faces && s.area > 0) return kDropped;
  // The pixels whose centres (px + 0.5, py + 0.5) lie in the corners' bounding box: no other can pass sample(). A
  // triangle between pixel centres (most of a dense mesh in a small image) has none and is dropped here.
  const double lo_x = ceil(min3(s.x[0], s.x[1], s.x[2]) - 0.5), hi_x = floor(max3(s.x[0], s.x[1], s.x[2]) - 0.5);
  const double lo_y = ceil(min3(s.y[0], s.y[1], s.y[2]) - 0.5), hi_y = floor(max3(s.y[0], s.y[1], s.y[2]) - 0.5);
  if (lo_x > hi_x || lo_y > hi_y) return kDropped;
  if (hi_x < 0 || hi_y < 0 || lo_x > in.width - 1 || lo_y > in.height - 1) return kDropped;
  s.x0 = lo_x < 0 ? 0 : int(lo_x);
  s.x1 = hi_x > in.width - 1 ? in.width - 1 : int(hi_x);
  s.y0 = lo_y < 0 ? 0 : int(lo_y);
  s.y1 = hi_y > in.height - 1 ? in.height - 1 : int(hi_y);
  return kLive;
}

// Pixel (px, py)'s centre against the triangle: false when outside; else its depth and perspective-correct b1, b2.
BARESKIN_HD bool sample(const Setup& s, int px, int py, bool orthographic, float& depth, float& b1, float& b2) {
  const double cx = px + 0.5, cy = py + 0.5;
  double l[3];
  for (int k = 0; k < 3; ++k) {
    const int a = (k + 1) % 3, b = (k + 2) % 3;
    l[k] = ((s.x[a] - cx) * (s.y[b] - cy) - (s.y[a] - cy) * (s.x[b] - cx)) / s.area;
  }
  if (l[0] < 0 || l[1] < 0 || l[2] < 0) return false;
  const double q = l[0] * s.inv_w[0] + l[1] * s.inv_w[1] + l[2] * s.inv_w[2];
  const double c1 = l[1] * s.inv_w[1] / q, c2 = l[2] * s.inv_w[2] / q;
  const double d = orthographic ? (1 - c1 - c2) * s.z[0] + c1 * s.z[1] + c2 * s.z[2] : 1 / q;
  depth = float(d) == 0.f ? 0.f : float(d);  // -0 → +0, so that the keys order as the floats do
  b1 = float(c1);
  b2 = float(c2);
  return true;
}

// The visibility key of a sample: smaller is nearer, ties go to the lower triangle id. kNoKey is the background.
constexpr uint64_t kNoKey = ~uint64_t(0);
BARESKIN_HD uint64_t depth_key(float depth, int32_t id) {
  uint32_t bits;
  memcpy(&bits, &depth, sizeof bits);
  bits = (bits & 0x80000000u) ? ~bits : (bits | 0x80000000u);  // IEEE order → unsigned order
  return (uint64_t(bits) << 32) | uint32_t(id);
}

// The CUDA rasterizer's first pass for one triangle, as lane `lane` of `lanes` sharing it: every covered pixel's key
// goes to atomic_min(pixel index, key). Returns the set-up result (lanes > 0 may ignore it).
template <class AtomicMin>
BARESKIN_HD SetupResult cover(const RasterInput& in, const float* xyw, const float* z, int64_t f, int lane, int lanes,
                              AtomicMin&& atomic_min) {
  Setup s;
  const SetupResult r = setup(in, xyw, z, f, s);
  if (r != kLive) return r;
  const int bw = s.x1 - s.x0 + 1;
  const int64_t n = int64_t(bw) * (s.y1 - s.y0 + 1);
  for (int64_t i = lane; i < n; i += lanes) {
    const int px = s.x0 + int(i % bw), py = s.y0 + int(i / bw);
    float depth, b1, b2;
    if (sample(s, px, py, z != nullptr, depth, b1, b2)) atomic_min(int64_t(py) * in.width + px, depth_key(depth, int32_t(f)));
  }
  return r;
}

// The second pass for one pixel: the winning triangle's id, barycentrics and depth from its key.
BARESKIN_HD void resolve(const RasterInput& in, const float* xyw, const float* z, uint64_t key, int px, int py,
                         int32_t& triangle, float* bary, float& depth) {
  triangle = -1;
  bary[0] = bary[1] = 0.f;
  depth = HUGE_VALF;
  if (key == kNoKey) return;
  const int32_t f = int32_t(uint32_t(key & 0xffffffffu));
  Setup s;
  if (setup(in, xyw, z, f, s) != kLive) return;
  float d, b1, b2;
  if (!sample(s, px, py, z != nullptr, d, b1, b2)) return;
  triangle = f;
  bary[0] = b1;
  bary[1] = b2;
  depth = d;
}

}  // namespace raster
}  // namespace bareskin
