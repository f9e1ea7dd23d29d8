#include "core/inspect.h"

#include <algorithm>
#include <limits>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "core/mesh_io.h"
#include "core/safetensors.h"

namespace bareskin {

nlohmann::json inspect_file(const std::string& path, bool stats, bool values) {
  const std::string ext = lower_extension(path);
  nlohmann::json j;
  j["file"] = path;
  if (ext == ".obj" || ext == ".ply") {
    const Mesh m = read_mesh(path);
    j["kind"] = "mesh";
    j["vertices"] = m.V.rows();
    j["triangles"] = m.F.rows();
    j["uvs"] = m.UV.rows();
    Eigen::MatrixX2d vertex_uv;
    j["uv_seams"] = m.has_uv() && !per_vertex_uv(m, vertex_uv);
    j["normals"] = m.has_normals();
    j["boundary_edges"] = boundary_edges(m.F).rows();
    j["surface_area"] = surface_area(m.V, m.F);
    const Eigen::RowVector3d lo = m.V.colwise().minCoeff(), hi = m.V.colwise().maxCoeff();
    j["bounding_box"] = {{lo.x(), lo.y(), lo.z()}, {hi.x(), hi.y(), hi.z()}};
  } else if (ext == ".safetensors") {
    const SafeTensors st = SafeTensors::open(path);
    j["kind"] = "safetensors";
    j["metadata"] = st.metadata();
    j["tensors"] = nlohmann::json::array();
    for (const std::string& name : st.names()) {
      const TensorView& t = st.tensor(name);
      nlohmann::json e{{"name", name}, {"dtype", dtype_name(t.dtype)}, {"shape", t.shape}};
      if (stats && t.numel() > 0) {
        double lo = std::numeric_limits<double>::infinity(), hi = -lo, sum = 0;
        for (int64_t i = 0; i < t.numel(); ++i) {
          const double v = t.as_double(i);
          lo = std::min(lo, v);
          hi = std::max(hi, v);
          sum += v;
        }
        e["min"] = lo;
        e["max"] = hi;
        e["mean"] = sum / double(t.numel());
      }
      if (values) {  // every element in row-major order of the shape (integers exact up to 2^53)
        nlohmann::json v = nlohmann::json::array();
        const bool integer = t.dtype != DType::F16 && t.dtype != DType::BF16 && t.dtype != DType::F32 && t.dtype != DType::F64;
        for (int64_t i = 0; i < t.numel(); ++i) {
          if (integer) v.push_back(int64_t(t.as_double(i)));
          else v.push_back(t.as_double(i));
        }
        e["values"] = v;
      }
      j["tensors"].push_back(e);
    }
  } else if (ext == ".json" || ext == ".pts") {
    const Landmarks lm = read_landmarks(path);
    j["kind"] = "landmarks";
    j["scheme"] = lm.scheme;
    j["units"] = lm.units;
    j["points"] = lm.points.rows();
    j["dimensions"] = lm.points.cols();
  } else {
    const ImageFileInfo info = probe_image(path);
    // Decode the pixels too (when they fit in memory comfortably), so a truncated file is reported as such.
    if (int64_t(info.width) * info.height * info.channels <= (int64_t(1) << 28)) read_image(path);
    j["kind"] = "image";
    j["format"] = info.format;
    j["width"] = info.width;
    j["height"] = info.height;
    j["channels"] = info.channels;
    j["pixel_type"] = to_string(info.type);
    j["color_space"] = to_string(info.color_space);
    j["tiled"] = info.tiled;
    j["mip_levels"] = info.mip_levels;
  }
  return j;
}

std::string inspect_text(const nlohmann::json& j) {
  std::ostringstream out;
  out << j["file"].get<std::string>() << ": " << j["kind"].get<std::string>() << "\n";
  for (const auto& [key, value] : j.items()) {
    if (key == "file" || key == "kind") continue;
    if (key == "tensors") {
      for (const auto& t : value) {
        out << "  " << t["name"].get<std::string>() << "  " << t["dtype"].get<std::string>() << " " << t["shape"].dump();
        if (t.contains("mean")) out << "  min " << t["min"] << " max " << t["max"] << " mean " << t["mean"];
        out << "\n";
      }
    } else {
      out << "  " << key << ": " << (value.is_string() ? value.get<std::string>() : value.dump()) << "\n";
    }
  }
  return out.str();
}

}  // namespace bareskin
