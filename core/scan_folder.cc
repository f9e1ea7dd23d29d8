#include "core/scan_folder.h"

#include <filesystem>

#include "core/error.h"
#include "core/image_io.h"
#include "core/mesh_io.h"

namespace bareskin {

std::string find_scan_mesh(const std::string& dir) {
  for (const char* name : {"mesh.ply", "mesh.obj"})
    if (std::filesystem::exists(dir + "/" + name)) return dir + "/" + name;
  return "";
}

std::string find_scan_map(const std::string& dir, const std::string& kind) {
  for (const char* ext : {".png", ".exr", ".tif", ".tiff"})
    if (std::filesystem::exists(dir + "/" + kind + ext)) return dir + "/" + kind + ext;
  return "";
}

TexturedScan read_textured_scan(const std::string& scan, const std::string& texture) {
  TexturedScan out;
  out.mesh_path = scan;
  std::string diffuse = texture;
  if (std::filesystem::is_directory(scan)) {
    out.mesh_path = find_scan_mesh(scan);
    if (out.mesh_path.empty()) throw InvalidInput(scan, "holds no mesh.ply or mesh.obj", "pass a scan folder");
    if (diffuse.empty()) diffuse = find_scan_map(scan, "diffuse");
  }
  out.mesh = read_mesh(out.mesh_path);
  if (!diffuse.empty()) out.diffuse = to_linear(read_image(diffuse));
  if (out.diffuse && !out.mesh.has_uv())
    throw InvalidInput(out.mesh_path, "has no UVs for its diffuse map", "pass --texture ''");
  return out;
}

}  // namespace bareskin
