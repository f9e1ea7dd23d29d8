#include "core/mesh_io.h"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <iostream>
#include <sstream>
#include <vector>

#include "core/files.h"
#include "core/error.h"

namespace bareskin {
namespace {

struct DoubleTraits : public OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
  typedef OpenMesh::Vec2d TexCoord2D;
};
using OmMesh = OpenMesh::PolyMesh_ArrayKernelT<DoubleTraits>;

// OpenMesh reports problems (non-manifold faces it drops, unreadable lines) on its own log streams and carries on.
// We capture them so that a dropped face becomes an error instead of a silently different mesh.
class CapturedOpenMeshLog {
 public:
  CapturedOpenMeshLog() : lock_(mutex()) {
    for (OpenMesh::mostream* s : streams()) {
      std::vector<bool> had;
      for (std::ostream* o : defaults()) had.push_back(s->disconnect(*o));
      had_.push_back(had);
      s->connect(buffer_);
    }
  }
  ~CapturedOpenMeshLog() {
    for (size_t i = 0; i < streams().size(); ++i) {
      streams()[i]->disconnect(buffer_);
      for (size_t k = 0; k < defaults().size(); ++k) {
        if (had_[i][k]) streams()[i]->connect(*defaults()[k]);
      }
    }
  }
  std::string text() {
    for (OpenMesh::mostream* s : streams()) s->flush();
    return buffer_.str();
  }

 private:
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static const std::vector<OpenMesh::mostream*>& streams() {
    static const std::vector<OpenMesh::mostream*> s{&omerr(), &omlog(), &omout()};
    return s;
  }
  static const std::vector<std::ostream*>& defaults() {
    static const std::vector<std::ostream*> d{&std::cerr, &std::clog, &std::cout};
    return d;
  }
  std::unique_lock<std::mutex> lock_;
  std::ostringstream buffer_;
  std::vector<std::vector<bool>> had_;
};


void check_extension(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext != ".obj" && ext != ".ply") {
    throw InvalidInput(path, "unsupported mesh format '" + ext + "'", "use .obj or .ply");
  }
}

std::string first_problem(const std::string& log) {
  static const char* markers[] = {"complex", "Could not", "could not", "Error", "error", "invalid", "Invalid", "Warning"};
  std::istringstream lines(log);
  std::string line;
  while (std::getline(lines, line)) {
    for (const char* m : markers) {
      if (line.find(m) != std::string::npos) return line;
    }
  }
  return {};
}

// OpenMesh's PLY reader loops forever on a header without end_header, so the header is checked here first.
void check_ply_header(const std::string& path, const std::string& bytes) {
  if (bytes.compare(0, 4, "ply\n") != 0 && bytes.compare(0, 5, "ply\r\n") != 0) {
    throw InvalidInput(path, "does not start with 'ply'", "the file is not a PLY mesh");
  }
  const size_t end = bytes.find("end_header");
  if (end == std::string::npos || end > (1u << 20)) {
    throw InvalidInput(path, "PLY header has no end_header line", "the file is truncated or corrupt");
  }
}

// OpenMesh skips OBJ lines it cannot parse (a "nan" coordinate, a face cut short) and carries on; check the text
// first so the user hears about the real fault with its line number. Returns the number of face lines.
size_t check_obj_text(const std::string& path, const std::string& bytes) {
  size_t line = 1, faces = 0;
  const auto bad = [&](const std::string& what, const std::string& hint) {
    throw InvalidInput(path, "line " + std::to_string(line) + ": " + what, hint);
  };
  const char* p = bytes.data();
  const char* const end = p + bytes.size();
  const auto is_space = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
  while (p < end) {
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
    if (!eol) eol = end;
    // Tokens of this line, as [begin, end) pointers.
    std::pair<const char*, const char*> tokens[8];
    int n = 0;
    for (const char* q = p; q < eol && n < 8;) {
      while (q < eol && is_space(*q)) ++q;
      const char* b = q;
      while (q < eol && !is_space(*q)) ++q;
      if (q > b) tokens[n++] = {b, q};
    }
    const auto is = [&](const char* key) {
      return n > 0 && size_t(tokens[0].second - tokens[0].first) == std::strlen(key) &&
             std::equal(tokens[0].first, tokens[0].second, key);
    };
    if (is("v")) {
      if (n < 4) bad("vertex has fewer than 3 coordinates", "the file is truncated or corrupt");
      for (int i = 1; i < 4; ++i) {
        const std::string text(tokens[i].first, tokens[i].second);
        char* stop = nullptr;
        const double value = std::strtod(text.c_str(), &stop);
        if (*stop != '\0') bad("vertex coordinate '" + text + "' is not a number", "the file is corrupt");
        if (!std::isfinite(value)) bad("vertex coordinate is NaN or infinite", "repair or remove that vertex");
      }
    } else if (is("f")) {
      ++faces;
      if (n < 4) bad("face has " + std::to_string(n - 1) + " corners", "the file is truncated or corrupt");
      for (int i = 1; i < n; ++i) {
        const char first = *tokens[i].first, last = *(tokens[i].second - 1);
        if (last == '/' || !(std::isdigit(static_cast<unsigned char>(first)) || first == '-')) {
          bad("malformed face corner '" + std::string(tokens[i].first, tokens[i].second) + "'",
              "the file is truncated or corrupt");
        }
      }
    }
    p = eol + 1;
    ++line;
  }
  return faces;
}

}  // namespace

Mesh read_mesh(const std::string& path) {
  check_extension(path);
  const std::string bytes = read_file(path);  // IoError with a clear message when missing or unreadable
  if (lower_extension(path) == ".ply") check_ply_header(path, bytes);
  const size_t obj_faces = lower_extension(path) == ".obj" ? check_obj_text(path, bytes) : 0;
  OmMesh om;
  om.request_vertex_texcoords2D();
  om.request_halfedge_texcoords2D();
  om.request_vertex_normals();
  OpenMesh::IO::Options opt = OpenMesh::IO::Options::VertexTexCoord | OpenMesh::IO::Options::FaceTexCoord |
                              OpenMesh::IO::Options::VertexNormal;
  bool ok;
  std::string log;
  {
    CapturedOpenMeshLog capture;
    ok = OpenMesh::IO::read_mesh(om, path, opt);
    log = capture.text();
  }
  if (!ok) {
    const std::string why = first_problem(log);
    throw InvalidInput(path, "cannot parse mesh" + (why.empty() ? std::string() : " (" + why + ")"),
                       "the file is truncated, corrupt or not a mesh");
  }
  if (const std::string why = first_problem(log); !why.empty()) {
    throw InvalidInput(path, "mesh reader rejected part of the file: " + why,
                       "repair the mesh (non-manifold or degenerate faces) before using it");
  }
  if (om.n_faces() == 0) throw InvalidInput(path, "has no faces", "the file is truncated or not a triangle mesh");
  if (obj_faces && om.n_faces() != obj_faces) {
    throw InvalidInput(path, "the reader kept " + std::to_string(om.n_faces()) + " of " + std::to_string(obj_faces) +
                                 " faces (degenerate or non-manifold faces)",
                       "repair the mesh before using it");
  }

  Mesh mesh;
  mesh.V.resize(om.n_vertices(), 3);
  for (auto v : om.vertices()) {
    const auto p = om.point(v);
    mesh.V.row(v.idx()) << p[0], p[1], p[2];
  }
  mesh.F.resize(om.n_faces(), 3);
  const bool corner_uv = opt.face_has_texcoord(), vertex_uv = !corner_uv && opt.vertex_has_texcoord();
  if (corner_uv) mesh.FUV.resize(om.n_faces(), 3);
  std::map<std::pair<double, double>, int> uv_index;  // OpenMesh keeps UVs per halfedge; index equal values once
  std::vector<std::pair<double, double>> uvs;
  for (auto f : om.faces()) {
    if (om.valence(f) != 3) {
      throw InvalidInput(path, "face " + std::to_string(f.idx()) + " has " + std::to_string(om.valence(f)) + " corners",
                         "triangulate the mesh first");
    }
    int corner = 0;
    for (auto h : om.fh_range(f)) {
      mesh.F(f.idx(), corner) = om.to_vertex_handle(h).idx();
      if (corner_uv) {
        const auto t = om.texcoord2D(h);
        auto [it, inserted] = uv_index.try_emplace({t[0], t[1]}, int(uvs.size()));
        if (inserted) uvs.emplace_back(t[0], t[1]);
        mesh.FUV(f.idx(), corner) = it->second;
      }
      ++corner;
    }
  }
  if (corner_uv) {
    mesh.UV.resize(uvs.size(), 2);
    for (size_t i = 0; i < uvs.size(); ++i) mesh.UV.row(i) << uvs[i].first, uvs[i].second;
  } else if (vertex_uv) {
    mesh.UV.resize(om.n_vertices(), 2);
    for (auto v : om.vertices()) mesh.UV.row(v.idx()) << om.texcoord2D(v)[0], om.texcoord2D(v)[1];
    mesh.FUV = mesh.F;
  }
  if (opt.vertex_has_normal()) {
    mesh.N.resize(om.n_vertices(), 3);
    for (auto v : om.vertices()) mesh.N.row(v.idx()) << om.normal(v)[0], om.normal(v)[1], om.normal(v)[2];
  }
  validate(mesh, path);
  return mesh;
}

void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options) {
  check_extension(path);
  validate(mesh, path);
  const bool ply = lower_extension(path) == ".ply";
  Eigen::MatrixX2d vertex_uv;
  if (ply && mesh.has_uv() && !per_vertex_uv(mesh, vertex_uv)) {
    throw InvalidInput(path, "PLY holds one texture coordinate per vertex but this mesh has UV seams",
                       "write an .obj instead");
  }
  OmMesh om;
  OpenMesh::IO::Options opt;
  const bool normals = options.write_normals && mesh.has_normals();
  if (normals) {
    om.request_vertex_normals();
    opt += OpenMesh::IO::Options::VertexNormal;
  }
  if (mesh.has_uv()) {
    if (ply) {
      om.request_vertex_texcoords2D();
      opt += OpenMesh::IO::Options::VertexTexCoord;
    } else {
      om.request_halfedge_texcoords2D();
      opt += OpenMesh::IO::Options::FaceTexCoord;
    }
  }
  if (ply && options.binary) opt += OpenMesh::IO::Options::Binary;
  std::vector<OmMesh::VertexHandle> vh(mesh.V.rows());
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
    vh[i] = om.add_vertex(OmMesh::Point(mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2)));
    if (normals) om.set_normal(vh[i], OmMesh::Normal(mesh.N(i, 0), mesh.N(i, 1), mesh.N(i, 2)));
    if (ply && mesh.has_uv()) om.set_texcoord2D(vh[i], OmMesh::TexCoord2D(vertex_uv(i, 0), vertex_uv(i, 1)));
  }
  {
    CapturedOpenMeshLog capture;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
      const auto fh = om.add_face(vh[mesh.F(f, 0)], vh[mesh.F(f, 1)], vh[mesh.F(f, 2)]);
      if (!fh.is_valid()) {
        throw InvalidInput(path, "face " + std::to_string(f) + " makes the mesh non-manifold",
                           "repair the mesh before writing it");
      }
      if (mesh.has_uv() && !ply) {
        int corner = 0;
        for (auto h : om.fh_range(fh)) {
          const int uv = mesh.FUV(f, corner++);
          om.set_texcoord2D(h, OmMesh::TexCoord2D(mesh.UV(uv, 0), mesh.UV(uv, 1)));
        }
      }
    }
  }
  if (mesh.has_uv() && !ply) {
    // The OBJ writer lists the texcoords of every halfedge, boundary ones included; give those the UV of a face
    // corner at the same vertex so they fold into an existing entry instead of writing uninitialised values.
    for (auto h : om.halfedges()) {
      if (!om.is_boundary(h)) continue;
      for (auto in : om.vih_range(om.to_vertex_handle(h))) {
        if (!om.is_boundary(in)) {
          om.set_texcoord2D(h, om.texcoord2D(in));
          break;
        }
      }
    }
  }
  AtomicFile out(path);
  bool ok;
  {
    CapturedOpenMeshLog capture;
    ok = OpenMesh::IO::write_mesh(om, out.temp_path(), opt, options.precision);
  }
  if (!ok) throw IoError(path, "cannot write mesh", "check free disk space and permissions");
  out.commit();
}

}  // namespace bareskin
