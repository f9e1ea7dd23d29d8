#include "template/mediapipe_face.h"

#include <cstring>
#include <regex>

#include "core/error.h"

namespace bareskin {
namespace {

// A minimal protobuf wire-format reader: varints, fixed32, length-delimited fields.
class ProtoReader {
 public:
  ProtoReader(const uint8_t* begin, const uint8_t* end, const std::string& source)
      : p_(begin), end_(end), source_(source) {}
  bool done() const { return p_ >= end_; }
  uint64_t varint() {
    uint64_t v = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (p_ >= end_) fail("varint runs past the end");
      const uint8_t b = *p_++;
      v |= uint64_t(b & 0x7f) << shift;
      if (!(b & 0x80)) return v;
    }
    fail("varint longer than 10 bytes");
  }
  float fixed32_float() {
    if (end_ - p_ < 4) fail("fixed32 runs past the end");
    float f;
    std::memcpy(&f, p_, 4);
    p_ += 4;
    return f;
  }
  ProtoReader sub_message() {
    const uint64_t n = varint();
    if (n > uint64_t(end_ - p_)) fail("length-delimited field runs past the end");
    ProtoReader sub(p_, p_ + n, source_);
    p_ += n;
    return sub;
  }
  void skip(uint32_t wire) {
    switch (wire) {
      case 0: varint(); break;
      case 1: advance(8); break;
      case 2: sub_message(); break;
      case 5: advance(4); break;
      default: fail("unsupported wire type " + std::to_string(wire));
    }
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw InvalidInput(source_, "malformed protobuf: " + what, "re-fetch the asset (make deps)");
  }

 private:
  void advance(size_t n) {
    if (size_t(end_ - p_) < n) fail("field runs past the end");
    p_ += n;
  }
  const uint8_t* p_;
  const uint8_t* end_;
  const std::string& source_;
};

void decode_mesh3d(ProtoReader reader, std::vector<float>& vertices, std::vector<uint32_t>& indices) {
  while (!reader.done()) {
    const uint64_t key = reader.varint();
    const uint32_t field = uint32_t(key >> 3), wire = uint32_t(key & 7);
    if (field == 3 && wire == 5) {
      vertices.push_back(reader.fixed32_float());
    } else if (field == 3 && wire == 2) {
      ProtoReader packed = reader.sub_message();
      while (!packed.done()) vertices.push_back(packed.fixed32_float());
    } else if (field == 4 && wire == 0) {
      indices.push_back(uint32_t(reader.varint()));
    } else if (field == 4 && wire == 2) {
      ProtoReader packed = reader.sub_message();
      while (!packed.done()) indices.push_back(uint32_t(packed.varint()));
    } else {
      reader.skip(wire);
    }
  }
}

std::string strip_comments(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size(); ++i) {
    if (text.compare(i, 2, "//") == 0) {
      i = text.find('\n', i);
      if (i == std::string::npos) break;
      out += '\n';
    } else if (text.compare(i, 2, "/*") == 0) {
      i = text.find("*/", i + 2);
      if (i == std::string::npos) break;
      ++i;
    } else {
      out += text[i];
    }
  }
  return out;
}

std::vector<int> parse_ints(const std::string& list) {
  std::vector<int> out;
  static const std::regex number(R"(-?\d+)");
  for (std::sregex_iterator it(list.begin(), list.end(), number), end; it != end; ++it) out.push_back(std::stoi(it->str()));
  return out;
}

// The text between the bracket that opens the initialiser of `marker` ("... = [") and its matching closing bracket.
std::string bracketed(const std::string& text, const std::string& marker, char open, char close) {
  const size_t at = text.find(marker);
  if (at == std::string::npos) return {};
  const size_t assign = text.find('=', at + marker.size());
  if (assign == std::string::npos) return {};
  const size_t begin = text.find(open, assign);
  if (begin == std::string::npos) return {};
  int depth = 0;
  for (size_t i = begin; i < text.size(); ++i) {
    if (text[i] == open) ++depth;
    if (text[i] == close && --depth == 0) return text.substr(begin + 1, i - begin - 1);
  }
  return {};
}

}  // namespace

CanonicalFace decode_canonical_face(const std::string& bytes, const std::string& source) {
  const auto* begin = reinterpret_cast<const uint8_t*>(bytes.data());
  ProtoReader reader(begin, begin + bytes.size(), source);
  std::vector<float> vertices;
  std::vector<uint32_t> indices;
  bool found = false;
  while (!reader.done()) {
    const uint64_t key = reader.varint();
    if ((key >> 3) == 1 && (key & 7) == 2) {
      decode_mesh3d(reader.sub_message(), vertices, indices);
      found = true;
    } else {
      reader.skip(uint32_t(key & 7));
    }
  }
  if (!found || vertices.empty() || indices.empty()) {
    throw InvalidInput(source, "holds no canonical mesh (field 1)", "is this geometry_pipeline_metadata_landmarks.binarypb?");
  }
  if (vertices.size() % 5 != 0 || indices.size() % 3 != 0) {
    throw InvalidInput(source, "vertex or index buffer length is not a multiple of 5 / 3", "re-fetch the asset");
  }
  CanonicalFace face;
  const Eigen::Index nv = Eigen::Index(vertices.size() / 5), nf = Eigen::Index(indices.size() / 3);
  face.V.resize(nv, 3);
  face.UV.resize(nv, 2);
  for (Eigen::Index i = 0; i < nv; ++i) {
    face.V.row(i) << vertices[5 * i], vertices[5 * i + 1], vertices[5 * i + 2];
    face.UV.row(i) << vertices[5 * i + 3], vertices[5 * i + 4];
  }
  if (!face.V.allFinite() || !face.UV.allFinite()) throw InvalidInput(source, "vertex buffer holds NaN/Inf", "");
  face.F.resize(nf, 3);
  for (Eigen::Index f = 0; f < nf; ++f) {
    for (int c = 0; c < 3; ++c) {
      const uint32_t idx = indices[3 * f + c];
      if (idx >= uint32_t(nv)) throw InvalidInput(source, "index " + std::to_string(idx) + " out of range", "");
      face.F(f, c) = int(idx);
    }
  }
  return face;
}

std::string extract_packed_asset(const std::string& bundle, const std::string& loader_js, const std::string& filename,
                                 const std::string& source) {
  const std::regex entry("\"filename\":\\s*\"[^\"]*" + std::regex_replace(filename, std::regex(R"([.])"), R"(\.)") +
                         "\",\\s*\"start\":\\s*(\\d+),\\s*\"end\":\\s*(\\d+)");
  std::smatch m;
  if (!std::regex_search(loader_js, m, entry)) {
    throw InvalidInput(source, "loader script lists no '" + filename + "'", "re-fetch the asset (make deps)");
  }
  const size_t start = std::stoull(m[1].str()), end = std::stoull(m[2].str());
  if (start > end || end > bundle.size()) throw InvalidInput(source, "byte range of '" + filename + "' lies outside", "");
  return bundle.substr(start, end - start);
}

FaceMeshTables parse_face_mesh_tables(const std::string& ts_source, const std::string& source) {
  const std::string text = strip_comments(ts_source);
  FaceMeshTables tables;
  tables.ibug68 = parse_ints(bracketed(text, "export const VTX68", '[', ']'));
  if (tables.ibug68.size() != 68) {
    throw InvalidInput(source, "VTX68 has " + std::to_string(tables.ibug68.size()) + " entries, expected 68",
                       "re-fetch @vladmandic/human (make deps)");
  }
  const std::string annotations = bracketed(text, "export const meshAnnotations", '{', '}');
  static const std::regex item(R"((\w+)\s*:\s*\[([^\]]*)\])");
  for (std::sregex_iterator it(annotations.begin(), annotations.end(), item), end; it != end; ++it) {
    tables.regions[(*it)[1].str()] = parse_ints((*it)[2].str());
  }
  if (!tables.regions.count("silhouette")) throw InvalidInput(source, "meshAnnotations has no silhouette", "");
  return tables;
}

}  // namespace bareskin
