#include "template/template_face.h"

#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Subdivider/Uniform/ModifiedButterFlyT.hh>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/assets.h"
#include "core/files.h"
#include "core/error.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "core/parallel.h"
#include "core/safetensors.h"
#include "template/surface.h"

namespace bareskin {
namespace {

struct DoubleTraits : public OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
};
using OmTriMesh = OpenMesh::TriMesh_ArrayKernelT<DoubleTraits>;

OmTriMesh to_openmesh(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F) {
  OmTriMesh om;
  std::vector<OmTriMesh::VertexHandle> vh;
  for (Eigen::Index i = 0; i < V.rows(); ++i) vh.push_back(om.add_vertex({V(i, 0), V(i, 1), V(i, 2)}));
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    if (!om.add_face(vh[F(f, 0)], vh[F(f, 1)], vh[F(f, 2)]).is_valid()) {
      throw InvalidInput("template", "face " + std::to_string(f) + " is non-manifold", "repair the template mesh");
    }
  }
  return om;
}

void from_openmesh(const OmTriMesh& om, Eigen::MatrixX3d& V, Eigen::MatrixX3i& F) {
  V.resize(om.n_vertices(), 3);
  for (auto v : om.vertices()) V.row(v.idx()) << om.point(v)[0], om.point(v)[1], om.point(v)[2];
  F.resize(om.n_faces(), 3);
  for (auto f : om.faces()) {
    int c = 0;
    for (auto v : om.fv_range(f)) F(f.idx(), c++) = v.idx();
  }
}

// Subdivides positions with the modified butterfly scheme and the UV layout linearly (a butterfly stencil can fold a
// planar layout over itself; the midpoint rule keeps it injective). One level at a time: the scheme keeps the old
// vertices first, and every new vertex splits an edge, so its old neighbours are that edge's two ends.
void butterfly(Eigen::MatrixX3d& V, Eigen::MatrixX2d& UV, Eigen::MatrixX3i& F, int levels) {
  OmTriMesh geometry = to_openmesh(V, F);
  OpenMesh::Subdivider::Uniform::ModifiedButterflyT<OmTriMesh> scheme;
  for (int level = 0; level < levels; ++level) {
    const int n_old = int(geometry.n_vertices());
    scheme.attach(geometry);
    scheme(1);
    scheme.detach();
    Eigen::MatrixX2d next(geometry.n_vertices(), 2);
    next.topRows(n_old) = UV;
    for (int i = n_old; i < int(geometry.n_vertices()); ++i) {
      Eigen::RowVector2d sum = Eigen::RowVector2d::Zero();
      int ends = 0;
      for (auto n : geometry.vv_range(OmTriMesh::VertexHandle(i))) {
        if (n.idx() < n_old) {
          sum += UV.row(n.idx());
          ++ends;
        }
      }
      BS_CHECK(ends == 2, "a subdivision vertex must split one edge");
      next.row(i) = sum / 2;
    }
    UV = next;
  }
  from_openmesh(geometry, V, F);
}

int nearest_vertex(const Eigen::MatrixX3d& V, const Eigen::RowVector3d& p) {
  Eigen::Index best;
  (V.rowwise() - p).rowwise().squaredNorm().minCoeff(&best);
  return int(best);
}

}  // namespace

void TemplateOptions::check() const {
  if (target_vertices < 500 || target_vertices > 2000000) {
    throw InvalidInput("", "--vertices must lie in [500, 2000000], got " + std::to_string(target_vertices), "");
  }
  if (remesh_iterations < 0 || remesh_iterations > 20) {
    throw InvalidInput("", "--remesh-iterations must lie in [0, 20]", "");
  }
}

TemplateFace coarse_template(const CanonicalFace& face, const FaceMeshTables& tables) {
  TemplateFace t;
  // MediaPipe's canonical face is in cm with +y up and +z out of the face, as ours; only the unit changes.
  t.mesh.V = face.V * 10.0;
  t.mesh.F = face.F;
  t.mesh.UV.resize(face.UV.rows(), 2);
  t.mesh.UV.col(0) = face.UV.col(0);
  t.mesh.UV.col(1) = (1.0 - face.UV.col(1).array()).matrix();  // v down -> OBJ's v up
  t.mesh.FUV = face.F;
  t.landmark_vertices = tables.ibug68;
  for (int id : t.landmark_vertices) {
    if (id < 0 || id >= face.V.rows()) throw InvalidInput("VTX68", "refers to vertex " + std::to_string(id), "");
  }
  for (const auto& [name, ids] : tables.regions) {
    // Iris points (468..477) exist only in MediaPipe's refined landmark set, not on the mesh.
    if (std::all_of(ids.begin(), ids.end(), [&](int i) { return i >= 0 && i < face.V.rows(); })) {
      t.regions[name] = ids;
    }
  }
  validate(t.mesh, "canonical face");
  return t;
}

TemplateFace refine_template(const TemplateFace& coarse, const TemplateOptions& options,
                             const ProgressCallback& progress) {
  options.check();
  Eigen::MatrixX2d coarse_uv;
  if (!per_vertex_uv(coarse.mesh, coarse_uv)) {
    throw InvalidInput("template", "refinement needs one UV per vertex (no seams)", "refine the template elsewhere");
  }
  // Progress in units of roughly equal time (measured at 65k vertices): subdivision 1, remeshing 16, UV transfer and
  // landmarks 2.
  const int steps = 1 + 16 + 2;
  report(progress, 0, steps, "subdivide");
  // 1. A smooth reference surface at least as dense as the target.
  Eigen::MatrixX3d V = coarse.mesh.V;
  Eigen::MatrixX2d UV = coarse_uv;
  Eigen::MatrixX3i F = coarse.mesh.F;
  int levels = 0;
  for (double n = double(V.rows()); n < options.target_vertices; n *= 4) ++levels;
  butterfly(V, UV, F, levels);
  report(progress, 1, steps, "remesh");

  // 2. Isotropic remeshing of the reference to an even edge length that gives the target count.
  TemplateFace dense;
  isotropic_remesh(V, F, options.target_vertices, options.remesh_iterations, dense.mesh.V, dense.mesh.F);
  report(progress, steps - 2, steps, "uv transfer");

  // 3. UVs: locate each new vertex on the reference surface and interpolate the subdivided UV layout there.
  const SurfaceLocator reference(V, F);
  dense.mesh.UV.resize(dense.mesh.V.rows(), 2);
  parallel_for(0, dense.mesh.V.rows(), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const SurfacePoint p = reference.locate(dense.mesh.V.row(i).transpose());
      dense.mesh.UV.row(i) = p.barycentric[0] * UV.row(F(p.face, 0)) + p.barycentric[1] * UV.row(F(p.face, 1)) +
                             p.barycentric[2] * UV.row(F(p.face, 2));
    }
  }, 1024);
  dense.mesh.FUV = dense.mesh.F;
  dense.mesh.N = vertex_normals(dense.mesh.V, dense.mesh.F);

  // 4. Landmarks and region contours: nearest new vertex to each coarse vertex (which lies on the surface, since
  //    butterfly subdivision interpolates).
  for (int id : coarse.landmark_vertices) dense.landmark_vertices.push_back(nearest_vertex(dense.mesh.V, coarse.mesh.V.row(id)));
  for (const auto& [name, ids] : coarse.regions) {
    std::vector<int>& out = dense.regions[name];
    for (int id : ids) {
      const int v = nearest_vertex(dense.mesh.V, coarse.mesh.V.row(id));
      if (out.empty() || out.back() != v) out.push_back(v);
    }
  }
  validate(dense.mesh, "refined template");
  report(progress, steps, steps, "done");
  return dense;
}

void write_template(const std::string& dir, const TemplateFace& face, const std::string& provenance) {
  make_directories(dir);
  write_mesh(dir + "/face.obj", face.mesh);

  nlohmann::json doc;
  doc["scheme"] = "ibug68";
  doc["units"] = "mm";
  doc["vertex_ids"] = face.landmark_vertices;
  doc["points"] = nlohmann::json::array();
  for (int v : face.landmark_vertices) doc["points"].push_back({face.mesh.V(v, 0), face.mesh.V(v, 1), face.mesh.V(v, 2)});
  write_file_atomic(dir + "/landmarks.json", doc.dump(1) + "\n");
  write_file_atomic(dir + "/regions.json", nlohmann::json(face.regions).dump(1) + "\n");

  SafeTensorsWriter st;
  const auto rows = [](const auto& M) { return std::vector<int64_t>{int64_t(M.rows()), int64_t(M.cols())}; };
  std::vector<float> v(face.mesh.V.size()), uv(face.mesh.UV.size());
  std::vector<int32_t> f(face.mesh.F.size()), fuv(face.mesh.FUV.size());
  for (Eigen::Index i = 0; i < face.mesh.V.rows(); ++i)
    for (int k = 0; k < 3; ++k) v[size_t(3 * i + k)] = float(face.mesh.V(i, k));
  for (Eigen::Index i = 0; i < face.mesh.UV.rows(); ++i)
    for (int k = 0; k < 2; ++k) uv[size_t(2 * i + k)] = float(face.mesh.UV(i, k));
  for (Eigen::Index i = 0; i < face.mesh.F.rows(); ++i)
    for (int k = 0; k < 3; ++k) f[size_t(3 * i + k)] = face.mesh.F(i, k), fuv[size_t(3 * i + k)] = face.mesh.FUV(i, k);
  st.add("vertices", rows(face.mesh.V), v);
  st.add("triangles", rows(face.mesh.F), f);
  st.add("uvs", rows(face.mesh.UV), uv);
  st.add("uv_triangles", rows(face.mesh.FUV), fuv);
  st.add("landmark_vertices", {int64_t(face.landmark_vertices.size())},
         std::vector<int32_t>(face.landmark_vertices.begin(), face.landmark_vertices.end()));
  st.set_metadata("format", "bareskin.template");
  st.set_metadata("format_version", "1");
  st.set_metadata("units", "mm");
  st.set_metadata("axes", "right-handed, +y up, +z toward the camera");
  st.set_metadata("uv_origin", "bottom-left");
  st.set_metadata("provenance", provenance);
  st.write(dir + "/face.safetensors");
  const Mesh written = read_mesh(dir + "/face.obj");  // the layout's fingerprint is of the vertices readers will see
  if (uses_node_mesh(written.V.rows(), kDefaultNodes))
    write_node_layout(dir + "/nodes.safetensors", make_node_layout(written.V, written.F, kDefaultNodes));
  else
    std::filesystem::remove(dir + "/nodes.safetensors");  // an older, denser template's
}

TemplateFace read_template(const std::string& obj_path, const std::string& landmarks_path) {
  TemplateFace t;
  t.mesh = read_mesh(obj_path);
  if (!t.mesh.has_uv()) throw InvalidInput(obj_path, "template has no texture coordinates", "unwrap it (UVs) first");
  const std::string text = read_file(landmarks_path);
  const auto doc = nlohmann::json::parse(text, nullptr, false);
  if (!doc.is_discarded() && doc.is_object() && doc.contains("vertex_ids") && doc["vertex_ids"].is_array()) {
    for (const auto& id : doc["vertex_ids"]) {
      if (!id.is_number_integer() || id.get<int>() < 0 || id.get<int>() >= t.mesh.V.rows()) {
        throw InvalidInput(landmarks_path, "vertex_ids holds an entry that is not a vertex of " + obj_path, "");
      }
      t.landmark_vertices.push_back(id.get<int>());
    }
    if (t.landmark_vertices.size() != kIbug68Count) {
      throw InvalidInput(landmarks_path, "vertex_ids has " + std::to_string(t.landmark_vertices.size()) + " entries, need 68", "");
    }
  } else {
    const Landmarks lm = read_landmarks(landmarks_path);
    if (lm.points.cols() != 3) throw InvalidInput(landmarks_path, "template landmarks must be 3D", "");
    for (Eigen::Index i = 0; i < lm.points.rows(); ++i) t.landmark_vertices.push_back(nearest_vertex(t.mesh.V, lm.points.row(i)));
  }
  const std::string regions = (std::filesystem::path(landmarks_path).parent_path() / "regions.json").string();
  if (std::filesystem::exists(regions)) {
    const auto r = nlohmann::json::parse(read_file(regions), nullptr, false);
    if (r.is_discarded() || !r.is_object()) throw InvalidInput(regions, "is not a JSON object of vertex lists", "");
    for (const auto& [name, ids] : r.items()) {
      if (!ids.is_array()) throw InvalidInput(regions, "region '" + name + "' is not a list", "");
      for (const auto& id : ids) {
        if (!id.is_number_integer() || id.get<int>() < 0 || id.get<int>() >= t.mesh.V.rows()) {
          throw InvalidInput(regions, "region '" + name + "' names a vertex outside the mesh", "");
        }
        t.regions[name].push_back(id.get<int>());
      }
    }
  }
  const std::string nodes = (std::filesystem::path(landmarks_path).parent_path() / "nodes.safetensors").string();
  if (std::filesystem::exists(nodes)) {
    NodeLayout layout = read_node_layout(nodes);
    // Kept only when made for this face.obj (after an edit it is stale: registrations make their own); a file that
    // claims to be but does not index this mesh is damaged.
    if (layout.template_fingerprint == node_layout_fingerprint(t.mesh.V, t.mesh.F, kDefaultNodes)) {
      const bool indexes = layout.node.size() == size_t(t.mesh.V.rows()) &&
                           std::all_of(layout.face.begin(), layout.face.end(),
                                       [&](int f) { return f >= 0 && f < t.mesh.F.rows(); });
      if (!indexes) throw InvalidInput(nodes, "does not index " + obj_path, "remake the folder with `bareskin template`");
      t.nodes = std::make_shared<const NodeLayout>(std::move(layout));
    }
  }
  return t;
}

std::string find_template_folder(const std::string& given) {
  return find_data_dir(DataKind::Template, given, "face.obj");
}

TemplateFace read_template_folder(const std::string& given) {
  const std::string dir = find_template_folder(given);
  return read_template(dir + "/face.obj", dir + "/landmarks.json");
}

}  // namespace bareskin
