// Decoding the MediaPipe canonical face (npm @mediapipe/face_mesh, Apache-2.0) and the iBUG-68 / region vertex
// tables of @vladmandic/human (MIT) — the raw material of our template face.
#pragma once
#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

namespace bareskin {

struct CanonicalFace {
  Eigen::MatrixX3d V;   // 468 by 3, centimetres, MediaPipe axes
  Eigen::MatrixX2d UV;  // 468 by 2, v pointing down (image convention)
  Eigen::MatrixX3i F;   // 898 by 3
};

// Decodes geometry_pipeline_metadata_landmarks.binarypb: message field 1 = Mesh3d { 3: vertex_buffer (x y z u v per
// vertex, floats, packed or not), 4: index_buffer (uint32, packed or not) }. InvalidInput naming `source` on any
// malformed varint, length, or a buffer whose sizes or indices are inconsistent.
CanonicalFace decode_canonical_face(const std::string& bytes, const std::string& source);

// Cuts one file out of an Emscripten packed-asset bundle using the loader script's {"filename", "start", "end"} table.
std::string extract_packed_asset(const std::string& bundle, const std::string& loader_js, const std::string& filename,
                                 const std::string& source);

struct FaceMeshTables {
  std::vector<int> ibug68;                        // VTX68: mesh vertex of each iBUG landmark
  std::map<std::string, std::vector<int>> regions; // meshAnnotations: lips/eyes/brows/silhouette contours
};

// Reads the number arrays out of facemeshcoords.ts (comments stripped). InvalidInput when VTX68 is missing or not 68.
FaceMeshTables parse_face_mesh_tables(const std::string& ts_source, const std::string& source);

}  // namespace bareskin
