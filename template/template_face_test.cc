#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "core/files.h"
#include "core/error.h"
#include "core/test_util.h"
#include "template/template_face.h"

namespace bareskin {
namespace {

std::string assets() { return BARESKIN_ASSETS_DIR; }

TemplateFace load_coarse() {
  const std::string mp = assets() + "/mediapipe_face_mesh/", bundle = mp + "face_mesh_solution_packed_assets.data";
  const CanonicalFace face = decode_canonical_face(
      extract_packed_asset(read_file(bundle), read_file(mp + "face_mesh_solution_packed_assets_loader.js"),
                           "geometry_pipeline_metadata_landmarks.binarypb", bundle),
      bundle);
  const std::string ts = assets() + "/human/facemeshcoords.ts";
  return coarse_template(face, parse_face_mesh_tables(read_file(ts), ts));
}

// Signed UV areas: negative = flipped.
int flipped_uv_triangles(const Mesh& m) {
  int flipped = 0;
  for (Eigen::Index f = 0; f < m.FUV.rows(); ++f) {
    const Eigen::RowVector2d a = m.UV.row(m.FUV(f, 0)), b = m.UV.row(m.FUV(f, 1)), c = m.UV.row(m.FUV(f, 2));
    const double area = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
    flipped += area < 0;
  }
  return flipped;
}

TEST(TemplateFace, CanonicalFaceDecodesAsPublished) {
  const TemplateFace coarse = load_coarse();
  EXPECT_EQ(coarse.mesh.V.rows(), 468);
  EXPECT_EQ(coarse.mesh.F.rows(), 898);
  EXPECT_EQ(coarse.landmark_vertices.size(), 68u);
  EXPECT_EQ(flipped_uv_triangles(coarse.mesh), 0);
  // Millimetres and our axes: a face ~15 cm wide, nose tip (VTX68 #30 = vertex 4) the most forward landmark area.
  const Eigen::RowVector3d size = coarse.mesh.V.colwise().maxCoeff() - coarse.mesh.V.colwise().minCoeff();
  EXPECT_GT(size.x(), 130);
  EXPECT_LT(size.x(), 180);
  const Eigen::RowVector3d nose = coarse.mesh.V.row(coarse.landmark_vertices[30]);
  const Eigen::RowVector3d chin = coarse.mesh.V.row(coarse.landmark_vertices[8]);
  const Eigen::RowVector3d brow = coarse.mesh.V.row(coarse.landmark_vertices[19]);
  EXPECT_GT(nose.z(), chin.z());  // +z toward the camera
  EXPECT_GT(brow.y(), chin.y());  // +y up
  // Landmark 36 (right eye outer corner, subject's right) lies at -x.
  EXPECT_LT(coarse.mesh.V(coarse.landmark_vertices[36], 0), 0);
  EXPECT_TRUE(coarse.regions.count("lipsUpperOuter"));
  EXPECT_FALSE(coarse.regions.count("rightEyeIris")) << "iris points are not mesh vertices";
}

TEST(TemplateFace, RefinementHitsTheSizeKeepsTheSurfaceAndTheUvLayout) {
  const TemplateFace coarse = load_coarse();
  TemplateOptions opt;
  opt.target_vertices = 6000;
  const TemplateFace dense = refine_template(coarse, opt);
  EXPECT_NEAR(double(dense.mesh.V.rows()), 6000, 6000 * 0.05);
  EXPECT_EQ(flipped_uv_triangles(dense.mesh), 0);
  // The interpolating subdivision keeps the coarse surface: landmarks land within one mean edge of their origin.
  double edge = 0;
  for (Eigen::Index f = 0; f < dense.mesh.F.rows(); ++f) {
    edge += (dense.mesh.V.row(dense.mesh.F(f, 0)) - dense.mesh.V.row(dense.mesh.F(f, 1))).norm();
  }
  edge /= double(dense.mesh.F.rows());
  for (size_t i = 0; i < 68; ++i) {
    const double d = (dense.mesh.V.row(dense.landmark_vertices[i]) - coarse.mesh.V.row(coarse.landmark_vertices[i])).norm();
    EXPECT_LT(d, edge) << "landmark " << i;
  }
  // Area changes little (the coarse mesh is already close to the smooth surface).
  EXPECT_NEAR(surface_area(dense.mesh.V, dense.mesh.F) / surface_area(coarse.mesh.V, coarse.mesh.F), 1.0, 0.03);
}

TEST(TemplateFace, WrittenTemplateReadsBackAsAUserTemplate) {
  const TemplateFace coarse = load_coarse();
  const std::string dir = testing::temp_dir() + "/template";
  write_template(dir, coarse, "test");
  const TemplateFace back = read_template(dir + "/face.obj", dir + "/landmarks.json");
  EXPECT_EQ(back.landmark_vertices, coarse.landmark_vertices);
  EXPECT_EQ(back.regions, coarse.regions);
  // A user template with only 3D landmark points snaps them to the nearest vertex.
  testing::write_text(dir + "/points.json", R"({"scheme":"custom","points":[[0,0,0]]})");
  EXPECT_EQ(read_template(dir + "/face.obj", dir + "/points.json").landmark_vertices.size(), 1u);
}

TEST(TemplateFace, CorruptAssetsAreRejected) {
  EXPECT_THROW(decode_canonical_face("", "x.binarypb"), InvalidInput);
  EXPECT_THROW(decode_canonical_face("\x0a\xff\xff\xff\xff\x0f", "x.binarypb"), InvalidInput);  // length past the end
  EXPECT_THROW(decode_canonical_face("\x0a\x02\x1d\x00", "x.binarypb"), InvalidInput);          // fixed32 cut short
  EXPECT_THROW(parse_face_mesh_tables("export const VTX68: number[] = [1, 2];", "x.ts"), InvalidInput);
  EXPECT_THROW(extract_packed_asset("abc", "{}", "face.binarypb", "x.data"), InvalidInput);
}

}  // namespace
}  // namespace bareskin
