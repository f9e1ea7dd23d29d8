#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <filesystem>

#include "core/files.h"
#include "core/error.h"
#include "core/mesh.h"
#include "core/mesh_io.h"
#include "core/test_util.h"

namespace bareskin {
namespace {

// A unit cube's six faces, each quad split in two, with a UV seam: every face has its own UV square, so the UV
// indices differ from the vertex indices.
Mesh seamed_cube() {
  Mesh m;
  m.V.resize(8, 3);
  for (int i = 0; i < 8; ++i) m.V.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  m.F.resize(12, 3);
  m.FUV.resize(12, 3);
  m.UV.resize(24, 2);
  for (int q = 0; q < 6; ++q) {
    const double u0 = q / 6.0 + 0.01, u1 = (q + 1) / 6.0 - 0.01;  // islands with gutters
    m.UV.row(4 * q + 0) << u0, 0;
    m.UV.row(4 * q + 1) << u1, 0;
    m.UV.row(4 * q + 2) << u1, 1;
    m.UV.row(4 * q + 3) << u0, 1;
    m.F.row(2 * q) << quads[q][0], quads[q][1], quads[q][2];
    m.F.row(2 * q + 1) << quads[q][0], quads[q][2], quads[q][3];
    m.FUV.row(2 * q) << 4 * q, 4 * q + 1, 4 * q + 2;
    m.FUV.row(2 * q + 1) << 4 * q, 4 * q + 2, 4 * q + 3;
  }
  return m;
}

// Compares meshes corner by corner: same positions, and the same UV value at every face corner.
void expect_same(const Mesh& a, const Mesh& b) {
  ASSERT_EQ(a.V.rows(), b.V.rows());
  ASSERT_EQ(a.F.rows(), b.F.rows());
  EXPECT_LT((a.V - b.V).cwiseAbs().maxCoeff(), 1e-7);
  for (Eigen::Index f = 0; f < a.F.rows(); ++f) {
    // OpenMesh may start a face at another corner: align by the first vertex.
    int shift = 0;
    while (shift < 3 && b.F(f, shift) != a.F(f, 0)) ++shift;
    ASSERT_LT(shift, 3) << "face " << f;
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(a.F(f, c), b.F(f, (c + shift) % 3));
      if (a.has_uv()) {
        EXPECT_LT((a.UV.row(a.FUV(f, c)) - b.UV.row(b.FUV(f, (c + shift) % 3))).norm(), 1e-7);
      }
    }
  }
}

TEST(Mesh, ObjRoundTripKeepsUvSeams) {
  const std::string dir = testing::temp_dir();
  const Mesh cube = seamed_cube();
  write_mesh(dir + "/cube.obj", cube);
  const Mesh back = read_mesh(dir + "/cube.obj");
  expect_same(cube, back);
  EXPECT_EQ(back.UV.rows(), 24);  // seams kept: 24 distinct UVs for 8 vertices
  EXPECT_EQ(testing::count_files(dir), 1u) << "no temporary left behind";
  // An open mesh: boundary halfedges must not leak texcoords into the file.
  Mesh open = cube;
  open.F.conservativeResize(10, 3);
  open.FUV.conservativeResize(10, 3);
  write_mesh(dir + "/open.obj", open);
  expect_same(open, read_mesh(dir + "/open.obj"));
}

TEST(Mesh, PlyRoundTripAsciiAndBinaryWithNormals) {
  const std::string dir = testing::temp_dir();
  Mesh cube = seamed_cube();
  cube.UV = cube.V.leftCols<2>();  // one UV per vertex: PLY can hold it
  cube.FUV = cube.F;
  cube.N = vertex_normals(cube.V, cube.F);
  for (bool binary : {true, false}) {
    write_mesh(dir + "/cube.ply", cube, {binary, true, 12});
    const Mesh back = read_mesh(dir + "/cube.ply");
    expect_same(cube, back);
    ASSERT_TRUE(back.has_normals());
    EXPECT_LT((back.N - cube.N).cwiseAbs().maxCoeff(), 1e-6);
  }
}

TEST(Mesh, PlyRefusesUvSeams) {
  const std::string dir = testing::temp_dir();
  EXPECT_THROW(write_mesh(dir + "/cube.ply", seamed_cube()), InvalidInput);
  EXPECT_EQ(testing::count_files(dir), 0u);
}

TEST(Mesh, NormalsAndAreaOfCube) {
  const Mesh cube = seamed_cube();
  EXPECT_NEAR(surface_area(cube.V, cube.F), 6.0, 1e-12);
  const Eigen::MatrixX3d N = vertex_normals(cube.V, cube.F);
  // Corner (1,1,1) points along the diagonal, outward.
  EXPECT_LT((N.row(7).transpose() - Eigen::Vector3d(1, 1, 1).normalized()).norm(), 0.2);
  EXPECT_GT(N.row(7).dot(Eigen::RowVector3d(1, 1, 1)), 0.0);
  EXPECT_EQ(boundary_edges(cube.F).rows(), 0);  // closed
  Mesh open = cube;
  open.F.conservativeResize(10, 3);
  EXPECT_EQ(boundary_edges(open.F).rows(), 4);  // one quad removed
}

class MeshBadInput : public ::testing::Test {
 protected:
  std::string dir = testing::temp_dir();
  std::string expect_invalid(const std::string& name, const std::string& text) {
    const std::string path = dir + "/" + name;
    testing::write_text(path, text);
    try {
      read_mesh(path);
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << "message names the file: " << e.what();
      return e.what();
    }
    ADD_FAILURE() << name << " was accepted";
    return {};
  }
};

TEST_F(MeshBadInput, Rejected) {
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  EXPECT_NE(expect_invalid("nan.obj", "v 0 0 nan\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").find("NaN"), std::string::npos);
  EXPECT_NE(expect_invalid("inf.obj", "v 0 0 0\nv 1 -INF 0\nv 0 1 0\nf 1 2 3\n").find("line 2"), std::string::npos);
  expect_invalid("range.obj", tri + "f 1 2 7\n");
  expect_invalid("uvrange.obj", tri + "vt 0 0\nf 1/1 2/2 3/3\n");
  expect_invalid("empty.obj", "");
  expect_invalid("garbage.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\n");
  // A binary PLY cut in the middle of its vertex list.
  Mesh cube = seamed_cube();
  cube.UV.resize(0, 2);
  cube.FUV.resize(0, 3);
  write_mesh(dir + "/whole.ply", cube);
  const std::string whole = read_file(dir + "/whole.ply");
  expect_invalid("truncated.ply", whole.substr(0, whole.size() / 2));
  // Non-manifold: three triangles on one edge.
  expect_invalid("nonmanifold.obj", tri + "v 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n");
  // An ASCII PLY whose values are not numbers of their types, which OpenMesh's stream misreads (an int index past
  // int's range sent it reading a length from the wrong place: 2 GB, found by tests/fuzz/fuzz_mesh).
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                             "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::string face = "3 0 1 2\n";
  testing::write_text(dir + "/ok.ply", header + "0 0 0\n1 0 0\n+0 1 0.5e0\n" + face);
  EXPECT_EQ(read_mesh(dir + "/ok.ply").F.rows(), 1);
  for (const auto& [name, body] : std::vector<std::pair<std::string, std::string>>{
           {"index.ply", "0 0 0\n1 0 0\n0 1 0\n3 33333333333333330 1 2\n"},
           {"glued.ply", "0 0 0\n1 0 0\n0 1 0231-.4\n" + face},
           {"float_range.ply", "0 0 0\n1e39 0 0\n0 1 0\n" + face},
           {"hex.ply", "0 0 0\n0x1 0 0\n0 1 0\n" + face},
           {"nan.ply", "0 0 0\nnan 0 0\n0 1 0\n" + face},
           {"short_list.ply", "0 0 0\n1 0 0\n0 1 0\n4 0 1 2\n"}})
    EXPECT_NE(expect_invalid(name, header + body).find("PLY body line"), std::string::npos) << name;
  EXPECT_THROW(read_mesh(dir + "/missing.obj"), IoError);
  EXPECT_THROW(read_mesh(dir + "/mesh.stl"), InvalidInput);
}

// Exports name a material library; the reader must not open it. "../dev/zero" beside a file in /tmp (found by
// tests/fuzz/fuzz_mesh) ran OpenMesh's reader out of memory, and a missing .mtl made it warn and the read fail.
TEST(Mesh, MaterialLinesAreNeitherFollowedNorRequired) {
  const std::string dir = testing::temp_dir();
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  std::error_code ec;
  std::filesystem::create_directories(dir + "/scan", ec);
  testing::write_text(dir + "/scan/zero.obj", "mtllib ../../../../../../../../dev/zero\n" + tri + "usemtl skin\nf 1 2 3\n");
  testing::write_text(dir + "/scan/missing.obj", "mtllib head.mtl\n" + tri + "usemtl skin\nf 1 2 3\n");
  testing::write_text(dir + "/scan/quad.obj", "\tmtllib head.mtl\n" + tri + "v 1 1 0\nusemtl skin\nf 1 2 4 3\n");
  EXPECT_EQ(read_mesh(dir + "/scan/zero.obj").F.rows(), 1);
  EXPECT_EQ(read_mesh(dir + "/scan/missing.obj").F.rows(), 1);
  EXPECT_EQ(read_mesh(dir + "/scan/quad.obj").F.rows(), 2);
}

// Artists' meshes come with quads: they are split on read (a quad along its shorter diagonal), UV seams kept.
TEST(Mesh, PolygonsAreTriangulatedKeepingUvSeams) {
  const std::string dir = testing::temp_dir();
  // Two quads sharing the edge between vertices 2 and 3 (1-based), each with its own UV square: a seam along the
  // shared edge. The first quad's 2-4 diagonal is the shorter one.
  testing::write_text(dir + "/quads.obj",
                      "v 0 0 0\nv 1 0 0\nv 1.8 1.8 0\nv 0 1 0\nv 2 0 0\nv 2 1 0\n"
                      "vt 0 0\nvt 0.4 0\nvt 0.4 0.4\nvt 0 0.4\nvt 0.6 0\nvt 1 0\nvt 1 0.4\nvt 0.6 0.4\n"
                      "f 1/1 2/2 3/3 4/4\nf 2/5 5/6 6/7 3/8\n");
  const Mesh m = read_mesh(dir + "/quads.obj");
  ASSERT_EQ(m.F.rows(), 4);
  ASSERT_EQ(m.FUV.rows(), 4);
  EXPECT_EQ(m.UV.rows(), 8);  // vertices 2 and 3 keep two UVs each: the seam
  double area = 0;
  for (Eigen::Index f = 0; f < m.F.rows(); ++f) {
    const Eigen::Vector3d a = m.V.row(m.F(f, 0)), b = m.V.row(m.F(f, 1)), c = m.V.row(m.F(f, 2));
    area += 0.5 * (b - a).cross(c - a).norm();
    for (int k = 0; k < 3; ++k) {  // each corner's UV is the one its quad gave that vertex
      const int v = m.F(f, k);
      const Eigen::Vector2d uv = m.UV.row(m.FUV(f, k));
      const bool left = uv.x() < 0.5;
      const double expected_x = left ? std::vector<double>{0, 0.4, 0.4, 0, 0, 0}[size_t(v)]
                                     : std::vector<double>{0, 0.6, 0.6, 0, 1, 1}[size_t(v)];
      EXPECT_NEAR(uv.x(), expected_x, 1e-6) << "face " << f << " corner " << k;  // OpenMesh keeps UVs as float
    }
  }
  EXPECT_NEAR(area, 1.8 + 1.0, 1e-6);  // the two quads' areas (shoelace)
  // The first quad is split along its shorter diagonal (vertices 2-4, 1-based), so no triangle holds both 1 and 3.
  for (Eigen::Index f = 0; f < 2; ++f) {
    const auto row = m.F.row(f);
    EXPECT_FALSE((row.array() == 0).any() && (row.array() == 2).any()) << "face " << f;
  }
}

TEST(Mesh, UnwritableDirectoryIsIoErrorWithoutPartialFile) {
  EXPECT_THROW(write_mesh("/nonexistent_dir/x.obj", seamed_cube()), IoError);
}

}  // namespace
}  // namespace bareskin
