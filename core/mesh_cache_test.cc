#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_cache.h"
#include "core/mesh_io.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

namespace fs = std::filesystem;

// A wavy 30 x 20 grid with UVs (a seam down the middle: the right half's UVs are their own) and normals, written as OBJ.
Mesh wavy_grid() {
  const int nx = 30, ny = 20;
  Mesh m;
  m.V.resize(nx * ny, 3);
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) m.V.row(y * nx + x) << x * 1.37, y * 0.91, std::sin(x * 0.7) * std::cos(y * 0.3) * 2.1;
  m.UV.resize(2 * nx * ny, 2);
  for (int y = 0; y < ny; ++y)
    for (int x = 0; x < nx; ++x) {
      m.UV.row(y * nx + x) << x / (nx - 1.0) * 0.49, y / (ny - 1.0);
      m.UV.row(nx * ny + y * nx + x) << 0.51 + x / (nx - 1.0) * 0.49, y / (ny - 1.0);
    }
  m.F.resize(2 * (nx - 1) * (ny - 1), 3);
  m.FUV.resize(m.F.rows(), 3);
  int f = 0;
  for (int y = 0; y + 1 < ny; ++y)
    for (int x = 0; x + 1 < nx; ++x) {
      const int a = y * nx + x, b = a + 1, c = a + nx, d = c + 1, uv = x >= nx / 2 ? nx * ny : 0;
      m.F.row(f) << a, b, d;
      m.FUV.row(f++) << a + uv, b + uv, d + uv;
      m.F.row(f) << a, d, c;
      m.FUV.row(f++) << a + uv, d + uv, c + uv;
    }
  m.N = vertex_normals(m.V, m.F);
  return m;
}

template <typename Matrix>
bool same_bits(const Matrix& a, const Matrix& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         std::memcmp(a.data(), b.data(), size_t(a.size()) * sizeof(typename Matrix::Scalar)) == 0;
}

void expect_same_bits(const Mesh& a, const Mesh& b) {
  EXPECT_TRUE(same_bits(a.V, b.V));
  EXPECT_TRUE(same_bits(a.F, b.F));
  EXPECT_TRUE(same_bits(a.UV, b.UV));
  EXPECT_TRUE(same_bits(a.FUV, b.FUV));
  EXPECT_TRUE(same_bits(a.N, b.N));
}

class MeshCache : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::temp_dir();
    obj_ = dir_ + "/mesh.obj";
    write_mesh(obj_, wavy_grid());
  }
  void TearDown() override { fs::remove_all(dir_); }
  // The cache made from the OBJ as it is now.
  void fill_cache() {
    MeshCacheUse use;
    read_mesh_cached(obj_, &use);
    ASSERT_EQ(use, MeshCacheUse::kWritten);
  }
  std::string dir_, obj_;
};

TEST_F(MeshCache, FirstReadWritesTheCacheAndTheNextReadsItBitForBit) {
  const Mesh truth = read_mesh(obj_);
  ASSERT_GT(truth.N.rows(), 0);
  ASSERT_NE(truth.UV.rows(), truth.V.rows());  // the seam survived
  MeshCacheUse use;
  expect_same_bits(read_mesh_cached(obj_, &use), truth);
  EXPECT_EQ(use, MeshCacheUse::kWritten);
  EXPECT_TRUE(fs::is_regular_file(mesh_cache_path(obj_)));
  expect_same_bits(read_mesh_cached(obj_, &use), truth);
  EXPECT_EQ(use, MeshCacheUse::kHit);
  EXPECT_EQ(testing::count_files(dir_), 2u);  // the OBJ and its cache, no temporary left
}

TEST_F(MeshCache, ChangedFileIsReadAgainEvenAtTheSameSize) {
  fill_cache();
  std::string text = read_file(obj_);
  const size_t at = text.find("\nv ") + 3;  // the first vertex's x: one digit changed, the size kept
  text[at] = text[at] == '1' ? '2' : '1';
  testing::write_text(obj_, text);
  const Mesh truth = read_mesh(obj_);
  MeshCacheUse use;
  const Mesh got = read_mesh_cached(obj_, &use);
  EXPECT_EQ(use, MeshCacheUse::kWritten);
  expect_same_bits(got, truth);
  read_mesh_cached(obj_, &use);
  EXPECT_EQ(use, MeshCacheUse::kHit);
}

TEST_F(MeshCache, CorruptOrTruncatedCacheIsIgnoredAndRewritten) {
  const Mesh truth = read_mesh(obj_);
  fill_cache();
  const std::string good = read_file(mesh_cache_path(obj_));
  std::string flipped = good, header_only = good.substr(0, 80);
  flipped[good.size() / 2] ^= 0x20;  // a byte of the vertex data
  std::string rows = good;
  rows[32] ^= 1;  // V's row count (after magic, version, byte order, size, hash): the sizes no longer add up
  for (const std::string& bad : {flipped, rows, good.substr(0, good.size() - 1), header_only, std::string(),
                                 std::string("not a cache at all")}) {
    testing::write_text(mesh_cache_path(obj_), bad);
    MeshCacheUse use;
    expect_same_bits(read_mesh_cached(obj_, &use), truth);
    EXPECT_EQ(use, MeshCacheUse::kWritten) << bad.size();
    EXPECT_EQ(read_file(mesh_cache_path(obj_)), good);
  }
}

TEST_F(MeshCache, BrokenFileIsRefusedWhateverTheCacheHolds) {
  fill_cache();
  std::string text = read_file(obj_);
  text.replace(text.find("\nv ") + 3, 3, "nan");
  testing::write_text(obj_, text);
  EXPECT_THROW(read_mesh_cached(obj_), InvalidInput);
  fs::remove(obj_);
  EXPECT_THROW(read_mesh_cached(obj_), IoError);
}

TEST_F(MeshCache, UnwritableCacheIsNoError) {
  fs::create_directory(mesh_cache_path(obj_));  // a folder where the cache would go
  MeshCacheUse use;
  expect_same_bits(read_mesh_cached(obj_, &use), read_mesh(obj_));
  EXPECT_EQ(use, MeshCacheUse::kNotWritten);
  EXPECT_EQ(testing::count_files(dir_), 2u);
}

}  // namespace
}  // namespace bareskin
