#include "core/mesh_io.h"

#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/Mesh/PolyMesh_ArrayKernelT.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <streambuf>
#include <iostream>
#include <set>
#include <sstream>
#include <vector>

#include "core/files.h"
#include "core/error.h"
#include "core/log.h"
#include "core/memory_limit.h"

namespace bareskin {
namespace {

struct DoubleTraits : public OpenMesh::DefaultTraits {
  typedef OpenMesh::Vec3d Point;
  typedef OpenMesh::Vec3d Normal;
  typedef OpenMesh::Vec2d TexCoord2D;
};
using OmMesh = OpenMesh::PolyMesh_ArrayKernelT<DoubleTraits>;

// OpenMesh reports problems (non-manifold faces it drops, unreadable lines) on its own log streams (omerr, omlog,
// omout) and carries on. We capture them so that a dropped face becomes an error instead of a silently different mesh.
// Each stream's buffer is replaced once per process by a router that passes text on to the stream's own buffer (and so
// to the terminal), or, while a CapturedOpenMeshLog exists, into the capture. (OpenMesh's own connect/disconnect of
// targets, done per read, leaked every target: its disconnect never deletes; found by tests/fuzz/fuzz_mesh.)
class LogRouter : public std::streambuf {
 public:
  explicit LogRouter(std::streambuf* original) : original_(original) {}
  void capture(std::string* into) {
    std::lock_guard<std::mutex> lock(mutex_);
    into_ = into;
  }

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    std::lock_guard<std::mutex> lock(mutex_);
    if (into_) {
      into_->push_back(traits_type::to_char_type(c));
      return c;
    }
    return original_ ? original_->sputc(traits_type::to_char_type(c)) : c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (into_) {
      into_->append(s, size_t(n));
      return n;
    }
    return original_ ? original_->sputn(s, n) : n;
  }
  int sync() override {
    std::lock_guard<std::mutex> lock(mutex_);
    return into_ || !original_ ? 0 : original_->pubsync();
  }

 private:
  std::streambuf* original_;
  std::string* into_ = nullptr;
  std::mutex mutex_;
};

class CapturedOpenMeshLog {
 public:
  CapturedOpenMeshLog() : lock_(mutex()) {
    for (LogRouter* r : routers()) r->capture(&text_);
  }
  ~CapturedOpenMeshLog() {
    flush();
    for (LogRouter* r : routers()) r->capture(nullptr);
  }
  std::string text() {
    flush();
    return text_;
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
  // Installed once; never freed, as the streams keep using them until the process ends.
  static const std::vector<LogRouter*>& routers() {
    static const std::vector<LogRouter*> r = [] {
      std::vector<LogRouter*> out;
      for (OpenMesh::mostream* s : streams()) {
        out.push_back(new LogRouter(s->rdbuf()));
        s->rdbuf(out.back());
      }
      return out;
    }();
    return r;
  }
  void flush() {
    for (OpenMesh::mostream* s : streams()) s->flush();
  }
  std::unique_lock<std::mutex> lock_;
  std::string text_;
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

// OpenMesh's PLY reader loops forever on some malformed headers (no end_header; an element line without its count,
// found by tests/fuzz/fuzz_mesh), so the header is checked here first, line by line, against the PLY grammar.
struct PlyElement {
  std::string name;
  unsigned long long count;
  struct Property {
    bool list;         // a length, then that many values; else one value
    std::string type;  // the value's type (a list's items')
  };
  std::vector<Property> properties;
};

// Whether an ASCII PLY value is a number of `type` as OpenMesh's reader (a C++ stream) reads it whole: digits, sign,
// point and exponent only (no "nan", "inf" or hex, which the stream stops at and then misreads the rest of the file),
// within its type's range, and for an integer type an integer ("33333333333333330" as an int index sent it reading
// a length from the wrong place: 2 GB, found by tests/fuzz/fuzz_mesh).
bool ply_number(const std::string& token, const std::string& type) {
  if (token.empty() || token.find_first_not_of("0123456789+-.eE") != std::string::npos) return false;
  static const std::map<std::string, std::pair<double, double>> kIntegers = {
      {"char", {-128, 127}},        {"int8", {-128, 127}},       {"uchar", {0, 255}},           {"uint8", {0, 255}},
      {"short", {-32768, 32767}},   {"int16", {-32768, 32767}},  {"ushort", {0, 65535}},        {"uint16", {0, 65535}},
      {"int", {-2147483648.0, 2147483647.0}}, {"int32", {-2147483648.0, 2147483647.0}},
      {"uint", {0, 4294967295.0}},  {"uint32", {0, 4294967295.0}}};
  char* stop = nullptr;
  errno = 0;  // out of range for its type: the stream fails there as well (it converts with strtof / strtod)
  const auto range = kIntegers.find(type);
  if (range == kIntegers.end()) {
    const bool single = type == "float" || type == "float32";
    const double value = single ? double(std::strtof(token.c_str(), &stop)) : std::strtod(token.c_str(), &stop);
    return *stop == '\0' && errno != ERANGE && std::isfinite(value);
  }
  const long long value = std::strtoll(token.c_str(), &stop, 10);
  return *stop == '\0' && errno != ERANGE && double(value) >= range->second.first &&
         double(value) <= range->second.second;
}

// An ASCII PLY body against its header: one line per item, each with exactly its properties' values, list lengths
// below 65536. OpenMesh reads on through a malformed body (a length taken from a vertex's coordinate), so it is checked
// here first.
void check_ply_ascii_body(const std::string& path, const std::string& body, const std::vector<PlyElement>& elements) {
  std::istringstream lines(body);
  std::string line;
  size_t number = 0;
  const auto bad = [&](const std::string& what) {
    throw InvalidInput(path, "PLY body line " + std::to_string(number) + ": " + what, "the file is truncated or corrupt");
  };
  for (const PlyElement& e : elements)
    for (unsigned long long item = 0; item < e.count; ++item) {
      do {
        if (!std::getline(lines, line)) bad("the file ends inside element '" + e.name + "'");
        ++number;
      } while (line.find_first_not_of(" \t\r") == std::string::npos);
      std::istringstream words(line);
      std::vector<std::string> w;
      for (std::string x; words >> x;) w.push_back(x);
      size_t at = 0;
      for (const PlyElement::Property& property : e.properties) {
        if (at >= w.size()) bad("too few values for element '" + e.name + "'");
        size_t values = 1;
        if (property.list) {
          char* stop = nullptr;
          const long length = std::strtol(w[at].c_str(), &stop, 10);
          if (*stop != '\0' || length < 0 || length > 65535) bad("list length '" + w[at] + "' is not a length");
          values = size_t(length);
          ++at;
        }
        if (at + values > w.size()) bad("too few values for element '" + e.name + "'");
        for (const size_t end_of_values = at + values; at < end_of_values; ++at)
          if (!ply_number(w[at], property.type))
            bad("value '" + w[at].substr(0, 30) + "' of element '" + e.name + "' is not a " + property.type);
      }
      if (at != w.size()) bad(std::to_string(w.size()) + " values where element '" + e.name + "' has " + std::to_string(at));
    }
}

void check_ply_header(const std::string& path, const std::string& bytes) {
  if (bytes.compare(0, 4, "ply\n") != 0 && bytes.compare(0, 5, "ply\r\n") != 0) {
    throw InvalidInput(path, "does not start with 'ply'", "the file is not a PLY mesh");
  }
  size_t end = bytes.find("\nend_header");  // a line of its own
  while (end != std::string::npos && bytes.compare(end + 11, 1, "\n") != 0 && bytes.compare(end + 11, 2, "\r\n") != 0)
    end = bytes.find("\nend_header", end + 1);
  if (end == std::string::npos || end > (1u << 20)) {
    throw InvalidInput(path, "PLY header has no end_header line", "the file is truncated or corrupt");
  }
  static const std::set<std::string> kWideTypes = {"int", "uint", "int32", "uint32", "float", "double", "float32",
                                                   "float64"};
  static const std::set<std::string> kTypes = {"char",  "uchar",  "short",   "ushort",  "int",   "uint",
                                               "float", "double", "int8",    "uint8",   "int16", "uint16",
                                               "int32", "uint32", "float32", "float64"};
  std::istringstream header(bytes.substr(0, end));
  std::string line;
  std::getline(header, line);  // "ply"
  bool in_element = false;     // a property belongs to the element above it
  bool ascii = false;
  std::vector<PlyElement> elements;
  for (int number = 2; std::getline(header, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::vector<std::string> w;
    for (std::string x; words >> x;) w.push_back(x);
    const auto count = [](const std::string& t) {
      return !t.empty() && t.size() < 19 && std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
    };
    if (number == 2 && (w.empty() || w[0] != "format"))
      throw InvalidInput(path, "PLY header line 2 is not its format line", "the file is corrupt or not a PLY mesh");
    const bool ok =
        w.empty() || w[0] == "comment" || w[0] == "obj_info" ||
        (w[0] == "format" && w.size() == 3 && number == 2 && w[2] == "1.0" &&
         (w[1] == "ascii" || w[1] == "binary_little_endian" || w[1] == "binary_big_endian")) ||
        (w[0] == "element" && w.size() == 3 && count(w[2])) ||
        (w[0] == "property" && in_element && w.size() == 3 && kTypes.count(w[1])) ||
        (w[0] == "property" && in_element && w.size() == 5 && w[1] == "list" && kTypes.count(w[2]) &&
         kTypes.count(w[3]));
    in_element = in_element || (!w.empty() && w[0] == "element");
    if (ok && !w.empty() && w[0] == "format") ascii = w[1] == "ascii";
    if (ok && !w.empty() && w[0] == "element") elements.push_back({w[1], std::stoull(w[2]), {}});
    if (ok && !w.empty() && w[0] == "property") {
      // A list's length type bounds its lengths (OpenMesh reads an ASCII length as int: "8248305321" asked for
      // billions of corners; a wide binary length the same): up to 16 bits.
      if (w[1] == "list" && kWideTypes.count(w[2]))
        throw InvalidInput(path, "PLY header line " + std::to_string(number) + ": list length type '" + w[2] +
                                     "' is wider than 16 bits", "write face lists with 'uchar' lengths");
      elements.back().properties.push_back({w[1] == "list", w[1] == "list" ? w[3] : w[1]});
    }
    if (ok && !w.empty() && w[0] == "element")  // what the reader will reserve, roughly 64 bytes an item
      check_memory(path, 64.0 * std::stod(w[2]), "PLY element '" + w[1] + "' of " + w[2] + " items");
    if (!ok)
      throw InvalidInput(path, "PLY header line " + std::to_string(number) + " ('" + line.substr(0, 60) +
                                   "') is not a PLY header line", "the file is corrupt or not a PLY mesh");
  }
  if (ascii) check_ply_ascii_body(path, bytes.substr(bytes.find('\n', end + 1) + 1), elements);
}

// A face corner "v", "v/vt", "v//vn" or "v/vt/vn": each index must name an element defined before it (1-based, or
// negative: counted back from the last). OpenMesh writes through an index past its arrays (found by
// tests/fuzz/fuzz_mesh), so the text is checked first.
template <typename Bad>
void check_corner(const std::string& corner, const std::array<long, 3>& defined, const Bad& bad) {
  static const char* const kWhat[] = {"vertex", "texture coordinate", "normal"};
  size_t begin = 0;
  for (int k = 0; k < 3 && begin <= corner.size(); ++k) {
    const size_t slash = corner.find('/', begin);
    const std::string field = corner.substr(begin, slash == std::string::npos ? std::string::npos : slash - begin);
    if (!field.empty() || k == 0) {
      char* stop = nullptr;
      const long index = std::strtol(field.c_str(), &stop, 10);
      if (field.empty() || *stop != '\0' || index == 0 || index > defined[size_t(k)] || index < -defined[size_t(k)])
        bad("face corner '" + corner + "' names " + kWhat[k] + " " + field + " of the " +
                std::to_string(defined[size_t(k)]) + " defined before it",
            "the file is truncated or corrupt");
    }
    if (slash == std::string::npos) break;
    begin = slash + 1;
  }
}

// Whitespace within an OBJ line as OpenMesh's reader (a C++ stream) splits it: form feed and vertical tab included,
// or a line such as "f\f/8c" would pass the checks as an unknown keyword and reach the reader as a face without
// corners (its assert).
bool obj_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v'; }

// OpenMesh skips OBJ lines it cannot parse (a "nan" coordinate, a face cut short) and carries on; check the text
// first so the user hears about the real fault with its line number. Returns the number of face lines; `polygons`:
// those with more than 3 corners.
size_t check_obj_text(const std::string& path, const std::string& bytes, size_t& polygons) {
  size_t line = 1, faces = 0;
  std::array<long, 3> defined{0, 0, 0};  // vertices, texture coordinates and normals so far
  polygons = 0;
  const auto bad = [&](const std::string& what, const std::string& hint) {
    throw InvalidInput(path, "line " + std::to_string(line) + ": " + what, hint);
  };
  const char* p = bytes.data();
  const char* const end = p + bytes.size();
  while (p < end) {
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
    if (!eol) eol = end;
    // Tokens of this line, as [begin, end) pointers.
    std::pair<const char*, const char*> tokens[8];
    int n = 0;
    for (const char* q = p; q < eol && n < 8;) {
      while (q < eol && obj_space(*q)) ++q;
      const char* b = q;
      while (q < eol && !obj_space(*q)) ++q;
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
      polygons += n > 4;
      std::istringstream corners(std::string(tokens[1].first, eol));  // every corner, however many
      for (std::string corner; corners >> corner;) {
        const char first = corner.front(), last = corner.back();
        if (last == '/' || !(std::isdigit(static_cast<unsigned char>(first)) || first == '-')) {
          bad("malformed face corner '" + corner + "'", "the file is truncated or corrupt");
        }
        check_corner(corner, defined, bad);
      }
    } else if (is("vt")) {
      ++defined[1];
    } else if (is("vn")) {
      ++defined[2];
    }
    if (is("v")) ++defined[0];
    p = eol + 1;
    ++line;
  }
  return faces;
}

// OpenMesh's OBJ reader opens the file an "mtllib" line names, relative to the OBJ's folder, and reads it whole: a
// path such as "../dev/zero" ran it out of memory (found by tests/fuzz/fuzz_mesh), and a scan whose .mtl was not
// copied beside it failed with a warning. Materials are not ours to read (maps come from `uvtools bake`), so their
// lines ("mtllib", "usemtl") are blanked, the line numbers kept, before the reader sees the text.
std::string without_materials(const std::string& bytes) {
  std::string out = bytes;
  for (size_t begin = 0; begin < out.size();) {
    size_t eol = out.find('\n', begin);
    if (eol == std::string::npos) eol = out.size();
    size_t word = begin;
    while (word < eol && obj_space(out[word])) ++word;
    size_t word_end = word;
    while (word_end < eol && !obj_space(out[word_end])) ++word_end;
    const std::string key = out.substr(word, word_end - word);
    if (key == "mtllib" || key == "usemtl") out.replace(begin, eol - begin, eol - begin, ' ');
    begin = eol + 1;
  }
  return out;
}

// OpenMesh's OBJ reader gives the corners of a polygon with texture coordinates the wrong UVs, so polygons are split
// in the text before it reads them: a quad along its shorter diagonal (the other one where that edge exists already:
// a second copy would make the surface non-manifold), a larger polygon as a fan from its first corner. Each corner
// keeps its own "v/vt/vn" token, so UV seams stay. Returns the text unchanged (and 0 polygons) when every face is a
// triangle; `faces`: the face lines of the result. check_obj_text has validated the numbers.
std::string triangulate_obj_polygons(const std::string& bytes, size_t& polygons, size_t& faces) {
  polygons = faces = 0;
  std::vector<std::string> lines;
  std::vector<Eigen::Vector3d> positions;
  std::vector<std::vector<std::string>> corners;  // per line: the face's corner tokens (empty: not a face)
  std::vector<std::vector<long>> ids;             // ... and their 0-based vertex indices
  std::set<std::pair<long, long>> edges;
  const auto edge = [](long a, long b) { return std::make_pair(std::min(a, b), std::max(a, b)); };
  std::istringstream in(bytes);
  for (std::string line; std::getline(in, line);) {
    lines.push_back(line);
    corners.emplace_back();
    ids.emplace_back();
    const bool v = line.rfind("v ", 0) == 0 || line.rfind("v\t", 0) == 0;
    const bool f = line.rfind("f ", 0) == 0 || line.rfind("f\t", 0) == 0;
    if (v) {
      std::istringstream t(line.substr(2));
      Eigen::Vector3d p = Eigen::Vector3d::Zero();
      t >> p.x() >> p.y() >> p.z();
      positions.push_back(p);
    }
    if (!f) continue;
    std::istringstream t(line.substr(2));
    for (std::string c; t >> c;) {
      const long i = std::strtol(c.c_str(), nullptr, 10);  // 1-based, or negative: relative to the vertices so far
      corners.back().push_back(c);
      ids.back().push_back(i > 0 ? i - 1 : long(positions.size()) + i);
    }
    const std::vector<long>& k = ids.back();
    for (size_t c = 0; c < k.size(); ++c) edges.insert(edge(k[c], k[(c + 1) % k.size()]));
    if (k.size() > 3) ++polygons;
  }
  if (polygons == 0) return bytes;
  const auto position = [&](long k) {
    return k >= 0 && k < long(positions.size()) ? positions[size_t(k)] : Eigen::Vector3d::Zero();
  };
  std::ostringstream out;
  for (size_t l = 0; l < lines.size(); ++l) {
    const std::vector<long>& k = ids[l];
    const size_t n = k.size();
    if (n <= 3) {
      out << lines[l] << '\n';
      faces += n > 0;
      continue;
    }
    size_t first = 0;
    if (n == 4) {
      const bool shorter_13 = (position(k[1]) - position(k[3])).squaredNorm() < (position(k[0]) - position(k[2])).squaredNorm();
      first = shorter_13 ? 1 : 0;
      if (edges.count(edge(k[first], k[first + 2]))) first = 1 - first;
      edges.insert(edge(k[first], k[first + 2]));
    }
    const std::vector<std::string>& c = corners[l];
    for (size_t j = 1; j + 1 < n; ++j) {
      out << "f " << c[first] << ' ' << c[(first + j) % n] << ' ' << c[(first + j + 1) % n] << '\n';
      ++faces;
    }
  }
  return out.str();
}

}  // namespace

// core/mesh_cache.cc keeps binary copies of what this returns: bump its kReaderVersion when the result for a file
// changes.
Mesh read_mesh(const std::string& path) {
  std::error_code ec;  // a path without an extension that is not there was meant as a file or a folder
  if (lower_extension(path).empty() && !std::filesystem::exists(path, ec)) {
    throw IoError(path, "no such file or folder", "check the path");
  }
  check_extension(path);
  const std::string bytes = read_file(path);  // IoError with a clear message when missing or unreadable
  const bool obj = lower_extension(path) == ".obj";
  if (!obj) check_ply_header(path, bytes);
  size_t polygons = 0, triangulated_faces = 0;
  const size_t obj_faces = obj ? check_obj_text(path, bytes, polygons) : 0;
  OmMesh om;
  om.request_vertex_texcoords2D();
  om.request_halfedge_texcoords2D();
  om.request_vertex_normals();
  OpenMesh::IO::Options opt = OpenMesh::IO::Options::VertexTexCoord | OpenMesh::IO::Options::FaceTexCoord |
                              OpenMesh::IO::Options::VertexNormal;
  const std::string obj_text =
      !obj ? std::string()
           : polygons > 0 ? triangulate_obj_polygons(without_materials(bytes), polygons, triangulated_faces)
                          : without_materials(bytes);
  if (polygons > 0) {
    spdlog::debug("{}: {} polygon(s) with more than 3 corners split into triangles", path, polygons);
  }
  bool ok;
  std::string log;
  {
    CapturedOpenMeshLog capture;
    if (obj) {  // from the text, which names no other file
      std::istringstream text(obj_text);
      ok = OpenMesh::IO::read_mesh(om, text, ".obj", opt);
    } else {
      ok = OpenMesh::IO::read_mesh(om, path, opt);
    }
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
  const size_t expected_faces = polygons > 0 ? triangulated_faces : obj_faces;
  if (obj_faces && om.n_faces() != expected_faces) {
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
  // Polygons left (from a PLY: UVs per vertex there) are split into triangles: a quad along its shorter diagonal, a
  // larger polygon as a fan from its first corner.
  const bool corner_uv = opt.face_has_texcoord(), vertex_uv = !corner_uv && opt.vertex_has_texcoord();
  std::map<std::pair<double, double>, int> uv_index;  // OpenMesh keeps UVs per halfedge; index equal values once
  std::vector<std::pair<double, double>> uvs;
  std::vector<std::array<int, 3>> tris, tri_uvs;
  tris.reserve(om.n_faces());
  size_t ply_polygons = 0;
  std::vector<int> corner_v, corner_t;
  for (auto f : om.faces()) {
    corner_v.clear();
    corner_t.clear();
    for (auto h : om.fh_range(f)) {
      corner_v.push_back(om.to_vertex_handle(h).idx());
      if (corner_uv) {
        const auto t = om.texcoord2D(h);
        auto [it, inserted] = uv_index.try_emplace({t[0], t[1]}, int(uvs.size()));
        if (inserted) uvs.emplace_back(t[0], t[1]);
        corner_t.push_back(it->second);
      }
    }
    const size_t k = corner_v.size();
    if (k > 3) ++ply_polygons;
    size_t first = 0;  // the fan's apex
    if (k == 4) {      // the shorter diagonal: 0-2 or 1-3
      const auto p = [&](size_t c) { return om.point(OpenMesh::VertexHandle(corner_v[c])); };
      if ((p(1) - p(3)).sqrnorm() < (p(0) - p(2)).sqrnorm()) first = 1;
    }
    for (size_t c = 1; c + 1 < k; ++c) {
      const size_t a = first, b = (first + c) % k, d = (first + c + 1) % k;
      tris.push_back({corner_v[a], corner_v[b], corner_v[d]});
      if (corner_uv) tri_uvs.push_back({corner_t[a], corner_t[b], corner_t[d]});
    }
  }
  if (ply_polygons > 0) {
    spdlog::debug("{}: {} polygon(s) with more than 3 corners split into triangles", path, ply_polygons);
  }
  mesh.F.resize(Eigen::Index(tris.size()), 3);
  if (corner_uv) mesh.FUV.resize(Eigen::Index(tris.size()), 3);
  for (size_t t = 0; t < tris.size(); ++t)
    for (int c = 0; c < 3; ++c) {
      mesh.F(Eigen::Index(t), c) = tris[t][size_t(c)];
      if (corner_uv) mesh.FUV(Eigen::Index(t), c) = tri_uvs[t][size_t(c)];
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

void MeshWriteOptions::check() const {
  if (precision < 1 || precision > 17)
    throw InvalidInput("mesh precision", std::to_string(precision) + " significant digits is outside [1, 17]",
                       "use 9 (the default) for float vertices, 17 for doubles");
}

void write_mesh(const std::string& path, const Mesh& mesh, const MeshWriteOptions& options) {
  options.check();
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
