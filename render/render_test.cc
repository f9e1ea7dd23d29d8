// The rasterizer against geometry: interpolating the world position with the barycentrics of a pixel and projecting it
// lands on the pixel's centre (perspective correctness); the nearer triangle wins; the tiled, threaded rasterizer
// equals the plain loop to the bit; back faces, triangles behind the camera, UV space; SH basis orthogonality.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <numeric>
#include <random>

#include "core/error.h"
#include "core/parallel.h"
#include "render/camera.h"
#include "render/rasterize.h"
#include "render/sh.h"

namespace bareskin {
namespace {

RasterInput input(const std::vector<float>& xyw, const std::vector<int32_t>& tri, int size, const std::vector<float>* z = nullptr) {
  RasterInput in;
  in.xyw = xyw.data();
  in.z = z && !z->empty() ? z->data() : nullptr;
  in.triangles = tri.data();
  in.vertex_count = int64_t(xyw.size() / 3);
  in.triangle_count = int64_t(tri.size() / 3);
  in.width = in.height = size;
  return in;
}

// Random triangles 150-400 mm in front of a front camera, facing it.
Eigen::MatrixX3d random_soup(int count, std::mt19937& rng, std::vector<int32_t>& tri) {
  std::uniform_real_distribution<double> xy(-60, 60), depth(-300, 100), d(-25, 25);
  Eigen::MatrixX3d V(3 * count, 3);
  for (int f = 0; f < count; ++f) {
    const Eigen::RowVector3d c(xy(rng), xy(rng), depth(rng));
    for (int k = 0; k < 3; ++k) V.row(3 * f + k) = c + Eigen::RowVector3d(d(rng), d(rng), d(rng));
    tri.insert(tri.end(), {3 * f, 3 * f + 1, 3 * f + 2});
  }
  return V;
}

TEST(Rasterize, BarycentricsArePerspectiveCorrect) {
  std::mt19937 rng(3);
  std::vector<int32_t> tri;
  const Eigen::MatrixX3d V = random_soup(40, rng, tri);
  const Camera cam = view_camera("front", 256, Eigen::Vector3d::Zero(), 500);
  std::vector<float> z;
  const std::vector<float> xyw = project_vertices(V, cam, z);
  const RasterOutput r = rasterize(input(xyw, tri, 256));
  int covered = 0;
  double worst = 0;
  for (int py = 0; py < 256; ++py)
    for (int px = 0; px < 256; ++px) {
      const size_t i = size_t(py) * 256 + size_t(px);
      const int f = r.triangle[i];
      if (f < 0) continue;
      ++covered;
      const double b1 = r.bary[2 * i], b2 = r.bary[2 * i + 1];
      const Eigen::Vector3d P = (1 - b1 - b2) * V.row(tri[3 * f]).transpose() + b1 * V.row(tri[3 * f + 1]).transpose() +
                                b2 * V.row(tri[3 * f + 2]).transpose();
      const Eigen::Vector3d p = cam.project(P);
      worst = std::max({worst, std::abs(p.x() - (px + 0.5)), std::abs(p.y() - (py + 0.5))});
      EXPECT_NEAR(p.z(), r.depth[i], 1e-3 * p.z());
    }
  EXPECT_GT(covered, 5000);
  EXPECT_LT(worst, 2e-3) << "pixels";
}

TEST(Rasterize, NearerTriangleWinsWhateverTheOrder) {
  // Two overlapping squares' worth of triangles at w = 2 and w = 1; ids in both orders.
  for (bool near_first : {true, false}) {
    const float wn = 1, wf = 2;
    std::vector<float> xyw = {10, 10, wf, 50, 10, wf, 10, 50, wf, 20, 20, wn, 60, 20, wn, 20, 60, wn};
    std::vector<int32_t> tri = near_first ? std::vector<int32_t>{3, 4, 5, 0, 1, 2} : std::vector<int32_t>{0, 1, 2, 3, 4, 5};
    const RasterOutput r = rasterize(input(xyw, tri, 64));
    const int near_id = near_first ? 0 : 1;
    EXPECT_EQ(r.triangle[25 * 64 + 25], near_id);
    EXPECT_FLOAT_EQ(r.depth[25 * 64 + 25], wn);
    EXPECT_EQ(r.triangle[12 * 64 + 12], 1 - near_id);  // only the far one covers (12, 12)
    EXPECT_EQ(r.triangle[5 * 64 + 5], -1);
  }
}

TEST(Rasterize, TiledEqualsReference) {
  std::mt19937 rng(11);
  std::vector<int32_t> tri;
  const Eigen::MatrixX3d V = random_soup(3000, rng, tri);
  for (const char* view : {"front", "left"}) {
    const Camera cam = view_camera(view, 300, Eigen::Vector3d::Zero(), 500);
    std::vector<float> z;
    const std::vector<float> xyw = project_vertices(V, cam, z);
    const RasterOutput a = rasterize(input(xyw, tri, 300)), b = rasterize_reference(input(xyw, tri, 300));
    EXPECT_EQ(a.triangle, b.triangle) << view;
    EXPECT_EQ(a.bary, b.bary) << view;
    EXPECT_EQ(a.depth, b.depth) << view;
  }
}

// Set-up's bounding box holds every pixel centre a triangle covers, and drops triangles that lie between pixel centres:
// against an oracle that tests every pixel of the image for every triangle, on a dense soup of tiny triangles (most
// between centres; a quarter with their lowest corner and a quarter with their highest corner on a pixel centre, the
// box's edge cases) in a small image.
TEST(Rasterize, BoundingBoxLosesNoPixelCentre) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> at(-1, 17), d(-0.6, 0.6), up(0.05, 0.6);
  std::vector<float> xyw;
  std::vector<int32_t> tri;
  for (int f = 0; f < 4000; ++f) {
    double cx = at(rng), cy = at(rng);
    const bool on_centre = f % 4 < 2, lowest = f % 4 == 0;
    if (on_centre) cx = std::round(cx) + 0.5, cy = std::round(cy) + 0.5;
    for (int k = 0; k < 3; ++k) {
      const double ox = k == 0 ? 0 : on_centre ? (lowest ? up(rng) : -up(rng)) : d(rng);
      const double oy = k == 0 ? 0 : on_centre ? (lowest ? up(rng) : -up(rng)) : d(rng);
      xyw.insert(xyw.end(), {float(cx + ox), float(cy + oy), 1.f + f * 1e-4f});
    }
    tri.insert(tri.end(), {3 * f, 3 * f + 1, 3 * f + 2});
  }
  const RasterInput in = input(xyw, tri, 16);
  const RasterOutput out = rasterize(in);
  std::vector<int32_t> oracle(16 * 16, -1);
  std::vector<float> nearest(16 * 16, HUGE_VALF);
  int dropped_between_centres = 0;
  for (int64_t f = 0; f < in.triangle_count; ++f) {
    raster::Setup s;
    const raster::SetupResult r = raster::setup(in, in.xyw, in.z, f, s);
    if (r == raster::kDropped) {
      ++dropped_between_centres;
      // recompute what set-up dropped, with the whole image as the box
      for (int k = 0; k < 3; ++k) {
        s.x[k] = xyw[size_t(3 * tri[size_t(3 * f + k)])];
        s.y[k] = xyw[size_t(3 * tri[size_t(3 * f + k)] + 1)];
        s.inv_w[k] = 1 / double(xyw[size_t(3 * tri[size_t(3 * f + k)] + 2)]);
        s.z[k] = 1 / s.inv_w[k];
      }
      s.area = (s.x[1] - s.x[0]) * (s.y[2] - s.y[0]) - (s.y[1] - s.y[0]) * (s.x[2] - s.x[0]);
      if (!(std::abs(s.area) > 1e-12)) continue;
    }
    for (int py = 0; py < 16; ++py)
      for (int px = 0; px < 16; ++px) {
        float depth, b1, b2;
        if (!raster::sample(s, px, py, false, depth, b1, b2)) continue;
        const size_t i = size_t(py) * 16 + size_t(px);
        if (depth < nearest[i] || (depth == nearest[i] && int32_t(f) < oracle[i])) nearest[i] = depth, oracle[i] = int32_t(f);
      }
  }
  EXPECT_EQ(out.triangle, oracle);
  EXPECT_GT(dropped_between_centres, 1000);  // most of the soup covers no centre
  EXPECT_GT(std::count_if(out.triangle.begin(), out.triangle.end(), [](int32_t t) { return t >= 0; }), 100);
}

// The CUDA rasterizer's algorithm (raster::cover then raster::resolve over 64-bit atomic minima), run here on CPU
// threads with the lanes of each warp interleaved in a shuffled order: it must equal rasterize() to the bit, ties,
// culling, weak perspective and triangles behind the camera included. The GPU itself is checked by
// render_torch_test's CudaMatchesCpu where there is one.
RasterOutput rasterize_by_keys(const RasterInput& in, uint64_t seed) {
  const size_t pixels = size_t(in.width) * size_t(in.height);
  std::vector<std::atomic<uint64_t>> keys(pixels);
  for (auto& k : keys) k.store(raster::kNoKey);
  const int lanes = 32;
  std::vector<int64_t> work(size_t(in.triangle_count) * lanes);
  std::iota(work.begin(), work.end(), 0);
  std::shuffle(work.begin(), work.end(), std::mt19937_64(seed));
  std::atomic<int64_t> behind{0};
  parallel_for(0, int64_t(work.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const int64_t t = work[size_t(i)], f = t / lanes;
      const int lane = int(t % lanes);
      const raster::SetupResult r = raster::cover(in, in.xyw, in.z, f, lane, lanes, [&](int64_t p, uint64_t key) {
        uint64_t old = keys[size_t(p)].load();
        while (key < old && !keys[size_t(p)].compare_exchange_weak(old, key)) {
        }
      });
      if (r == raster::kBehind && lane == 0) ++behind;
    }
  }, 256);
  RasterOutput out;
  out.width = in.width;
  out.height = in.height;
  out.triangle.resize(pixels);
  out.bary.resize(2 * pixels);
  out.depth.resize(pixels);
  out.dropped_behind = behind;
  for (size_t p = 0; p < pixels; ++p) {
    raster::resolve(in, in.xyw, in.z, keys[p], int(p % size_t(in.width)), int(p / size_t(in.width)), out.triangle[p],
                    &out.bary[2 * p], out.depth[p]);
  }
  return out;
}

TEST(Rasterize, CudaAlgorithmOnCpuThreadsEqualsTiled) {
  std::mt19937 rng(17);
  std::vector<int32_t> tri;
  Eigen::MatrixX3d V = random_soup(3000, rng, tri);
  // Ties: a copy of the first 200 triangles under higher ids (same depth: the lower id must win), and one triangle
  // with a vertex behind the camera.
  for (int f = 0; f < 200; ++f) tri.insert(tri.end(), {tri[3 * size_t(f)], tri[3 * size_t(f) + 1], tri[3 * size_t(f) + 2]});
  V(0, 2) = 900;
  for (const char* view : {"front", "left"})
    for (bool cull : {false, true}) {
      const Camera cam = view_camera(view, 200, Eigen::Vector3d::Zero(), 500);
      std::vector<float> z;
      const std::vector<float> xyw = project_vertices(V, cam, z);
      RasterInput in = input(xyw, tri, 200);
      in.cull_back_faces = cull;
      const RasterOutput a = rasterize(in), b = rasterize_by_keys(in, cull ? 1 : 2);
      EXPECT_EQ(a.triangle, b.triangle) << view << cull;
      EXPECT_EQ(a.bary, b.bary) << view << cull;
      EXPECT_EQ(a.depth, b.depth) << view << cull;
      EXPECT_EQ(a.dropped_behind, b.dropped_behind);
      if (view[0] == 'f') {
        EXPECT_EQ(b.dropped_behind, 2) << "triangle 0 and its copy";
      }
    }
  Camera weak;  // weak perspective: depths to test in z, some negative
  weak.model = Camera::Model::WeakPerspective;
  weak.scale = 1.5;
  weak.cx = weak.cy = 100;
  weak.width = weak.height = 200;
  weak.t = Eigen::Vector3d(0, 0, -100);
  std::vector<float> z;
  const std::vector<float> xyw = project_vertices(V, weak, z);
  const RasterInput in = input(xyw, tri, 200, &z);
  const RasterOutput a = rasterize(in), b = rasterize_by_keys(in, 3);
  EXPECT_TRUE(std::any_of(z.begin(), z.end(), [](float d) { return d < 0; }));
  EXPECT_EQ(a.triangle, b.triangle);
  EXPECT_EQ(a.bary, b.bary);
  EXPECT_EQ(a.depth, b.depth);
}

TEST(Rasterize, BackFacesAndTrianglesBehindTheCamera) {
  // Seen from the front camera, (−1,−1), (1,−1), (0,1) in the z = 0 plane is counter-clockwise: front-facing.
  Eigen::MatrixX3d V(6, 3);
  V << -50, -50, 0, 50, -50, 0, 0, 50, 0,   //
      -50, -50, 0, 0, 50, 0, 50, -50, 0;    // the same, wound the other way
  const Camera cam = view_camera("front", 64, Eigen::Vector3d::Zero(), 500);
  std::vector<float> z;
  const std::vector<float> xyw = project_vertices(V, cam, z);
  RasterInput in = input(xyw, {0, 1, 2}, 64);
  std::vector<int32_t> front = {0, 1, 2}, back = {3, 4, 5};
  in.triangles = front.data();
  in.cull_back_faces = true;
  EXPECT_EQ(rasterize(in).triangle[32 * 64 + 32], 0);
  in.triangles = back.data();
  EXPECT_EQ(rasterize(in).triangle[32 * 64 + 32], -1);
  in.cull_back_faces = false;
  EXPECT_EQ(rasterize(in).triangle[32 * 64 + 32], 0);

  Eigen::MatrixX3d B = V.topRows(3);
  B(2, 2) = 800;  // behind the camera (which sits at z = 500)
  const std::vector<float> xyw_b = project_vertices(B, cam, z);
  const RasterOutput r = rasterize(input(xyw_b, front, 64));
  EXPECT_EQ(r.dropped_behind, 1);
  for (int32_t t : r.triangle) EXPECT_EQ(t, -1);
  std::vector<float> nan = xyw;
  nan[4] = NAN;
  EXPECT_THROW(rasterize(input(nan, front, 64)), InvalidInput);
}

TEST(Rasterize, WeakPerspectiveAndUvSpace) {
  Mesh quad;
  quad.V.resize(4, 3);
  quad.V << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  quad.F.resize(2, 3);
  quad.F << 0, 1, 2, 0, 2, 3;
  quad.UV = quad.V.leftCols(2);
  quad.FUV = quad.F;
  const RasterOutput r = rasterize_uv(quad, 32);
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> fuv = quad.FUV;
  std::vector<float> uv;
  for (Eigen::Index i = 0; i < quad.UV.rows(); ++i) uv.insert(uv.end(), {float(quad.UV(i, 0)), float(quad.UV(i, 1))});
  const std::vector<float> at = interpolate(r, fuv.data(), uv.data(), 2);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x) {
      const size_t i = size_t(y) * 32 + size_t(x);
      ASSERT_GE(r.triangle[i], 0) << "every texel of the unit square is covered";
      EXPECT_NEAR(at[2 * i], (x + 0.5) / 32, 1e-6);
      EXPECT_NEAR(at[2 * i + 1], 1 - (y + 0.5) / 32, 1e-6);
    }
  Camera weak;
  weak.model = Camera::Model::WeakPerspective;
  weak.scale = 20;
  weak.cx = weak.cy = 16;
  weak.width = weak.height = 32;
  std::vector<float> z;
  const std::vector<float> xyw = project_vertices(quad.V, weak, z);
  ASSERT_EQ(z.size(), 4u);
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> f = quad.F;
  const RasterOutput w = rasterize(input(xyw, std::vector<int32_t>(f.data(), f.data() + 6), 32, &z));
  EXPECT_GE(w.triangle[10 * 32 + 20], 0);  // x = 0.2 mm..., inside the 20 px square right of and above the centre
  EXPECT_FLOAT_EQ(w.depth[10 * 32 + 20], 1000);
}

TEST(SphericalHarmonics, BasisIsOrthogonalAndAmbientIsConstant) {
  // Quadrature over the sphere (midpoint in cos(theta) and phi).
  const int n = 200;
  double gram[9][9] = {};
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < 2 * n; ++j) {
      const double ct = -1 + (i + 0.5) * 2.0 / n, st = std::sqrt(1 - ct * ct), phi = (j + 0.5) * M_PI / n;
      const std::array<double, 9> Y = sh_basis({st * std::cos(phi), st * std::sin(phi), ct});
      for (int a = 0; a < 9; ++a)
        for (int b = 0; b < 9; ++b) gram[a][b] += Y[size_t(a)] * Y[size_t(b)] * (2.0 / n) * (M_PI / n);
    }
  for (int a = 0; a < 9; ++a)
    for (int b = 0; b < 9; ++b) {
      if (a != b) {
        EXPECT_NEAR(gram[a][b], 0, 1e-3) << a << "," << b;
      }
    }
  // Each band's functions have the same norm (a_l^2 c_l^2 4π/(2l+1) for the orthonormal Y_lm times a_l).
  EXPECT_NEAR(gram[1][1], gram[2][2], 1e-3);
  EXPECT_NEAR(gram[4][4], gram[6][6], 1e-3);
  EXPECT_NEAR(gram[4][4], gram[8][8], 1e-3);
  double gamma[27] = {};
  gamma[0] = gamma[9] = gamma[18] = kDeep3dAmbient;
  const Eigen::Vector3d e = sh_irradiance(Eigen::Vector3d(0.3, -0.5, 0.81).normalized(), gamma);
  EXPECT_NEAR(e.x(), kDeep3dAmbient * std::sqrt(M_PI) / 2, 1e-12);
  EXPECT_DOUBLE_EQ(e.x(), e.z());
}

// Pinned to Deep3DFaceRecon's numbers, not to our formula: its band products a_l c_l are 0.886227, 1.772454 and
// 2.427032, and its basis at the unit normal (0.48, -0.6, 0.64), in its order and signs
// [a0c0, -a1c1 y, a1c1 z, -a1c1 x, a2c2 xy, -a2c2 yz, a2c2 (3z^2-1)/(2 sqrt 3), -a2c2 xz, a2c2 (x^2-y^2)/2], written out.
TEST(SphericalHarmonics, MatchesDeep3dFaceReconNumbers) {
  const ShScales k = sh_scales();
  EXPECT_NEAR(k.k0, 0.886227, 1e-6);
  EXPECT_NEAR(k.k1, 1.772454, 1e-6);
  EXPECT_NEAR(k.k2, 2.427032, 1e-6);
  const double expected[9] = {0.886227, 1.063472, 1.134370, -0.850778, -0.698985, 0.931980, 0.160303, -0.745584, -0.157272};
  const std::array<double, 9> Y = sh_basis({0.48, -0.6, 0.64});
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(Y[size_t(i)], expected[i], 1e-6) << "basis function " << i;
}

}  // namespace
}  // namespace bareskin
