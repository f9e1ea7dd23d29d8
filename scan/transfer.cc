#include "scan/transfer.h"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/stats.h"
#include "core/image_io.h"
#include "core/scan_folder.h"
#include "template/surface.h"

namespace bareskin {

MapSelection ScanMaps::present() const {
  MapSelection s;
  s.diffuse = !diffuse.empty();
  s.normal = !normal.empty();
  s.roughness = !roughness.empty();
  s.specular = !specular.empty();
  return s;
}

std::vector<std::string> ScanMaps::names() const {
  std::vector<std::string> out;
  const MapSelection s = present();
  if (s.diffuse) out.push_back("diffuse");
  if (s.normal) out.push_back("normal");
  if (s.roughness) out.push_back("roughness");
  if (s.specular) out.push_back("specular");
  return out;
}

ScanAtlasPoint scan_atlas_point(const Eigen::MatrixX3d& V, const Eigen::MatrixX3i& F, int face, const Eigen::Vector3d& b,
                                const Mesh& scan, const SurfaceLocator& scan_locator) {
  ScanAtlasPoint out;
  const Eigen::Vector3d p = b[0] * V.row(F(face, 0)).transpose() + b[1] * V.row(F(face, 1)).transpose() +
                            b[2] * V.row(F(face, 2)).transpose();
  if (!p.allFinite()) return out;
  out.on_scan = scan_locator.locate(p);
  const SurfacePoint& s = out.on_scan;
  if (s.face < 0 || s.face >= scan.FUV.rows() || !s.barycentric.allFinite()) return out;
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    q += s.barycentric[k] * scan.V.row(scan.F(s.face, k)).transpose();
    out.uv += s.barycentric[k] * scan.UV.row(scan.FUV(s.face, k)).transpose();
  }
  out.ok = (q - s.point).norm() <= 1e-3;
  return out;
}

ScanMaps read_scan_maps(const std::string& dir) {
  ScanMaps maps;
  if (const std::string p = find_scan_map(dir, "diffuse"); !p.empty()) maps.diffuse = to_linear(read_image(p));
  if (const std::string p = find_scan_map(dir, "normal"); !p.empty()) {
    maps.normal = read_image(p, ColorSpace::Data);
    if (maps.normal.channels < 3) {
      throw InvalidInput(p, "a normal map needs 3 channels, it has " + std::to_string(maps.normal.channels),
                         "give a tangent-space RGB normal map, or remove it");
    }
  }
  if (const std::string p = find_scan_map(dir, "roughness"); !p.empty()) maps.roughness = read_image(p, ColorSpace::Data);
  if (const std::string p = find_scan_map(dir, "specular"); !p.empty()) maps.specular = read_image(p, ColorSpace::Data);
  return maps;
}

TransferResult transfer_maps(const Mesh& registered, const Mesh& scan, const ScanMaps& maps, const BakeOptions& options,
                             const std::string& out_dir, const ProgressCallback& progress) {
  if (!registered.has_uv()) throw InvalidInput("template", "has no UVs to transfer maps into", "use a template with UVs");
  if (!scan.has_uv()) throw InvalidInput("scan", "has no UV atlas, so its maps cannot be read", "give a scan with UVs");
  const MapSelection which = maps.present();
  if (!which.any()) throw InternalError("transfer_maps: no maps to transfer");
  Mesh target = registered, source = scan;
  target.N = vertex_normals(target.V, target.F);
  source.N = vertex_normals(source.V, source.F);
  const Eigen::MatrixX4d target_tangents = uv_tangents(target), source_tangents = uv_tangents(source);
  const SurfaceLocator locator(source.V, source.F);
  // Scan faces touching a seam of its atlas: a vertex with more than one UV.
  std::vector<int> uv_of(size_t(source.V.rows()), -1);
  std::vector<bool> seam_vertex(size_t(source.V.rows()), false);
  for (Eigen::Index f = 0; f < source.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      int& u = uv_of[size_t(source.F(f, k))];
      if (u >= 0 && u != source.FUV(f, k) && !source.UV.row(u).isApprox(source.UV.row(source.FUV(f, k)))) {
        seam_vertex[size_t(source.F(f, k))] = true;
      }
      u = source.FUV(f, k);
    }

  TransferResult result;
  const int R = options.resolution;
  result.texel_class.assign(size_t(R) * size_t(R), 0);
  write_uv_maps(target, options, out_dir, [&](int f, const Eigen::Vector3f& b, int x, int y) {
    const ScanAtlasPoint a = scan_atlas_point(target.V, target.F, f, b.cast<double>(), source, locator);
    const SurfacePoint& s = a.on_scan;
    if (s.face < 0) return MapTexel{};  // a non-finite registered point: no chart (class 0)
    const Eigen::Vector2d& uv = a.uv;
    bool seam = false;
    for (int k = 0; k < 3; ++k) seam = seam || seam_vertex[size_t(source.F(s.face, k))];
    result.texel_class[size_t(y) * size_t(R) + size_t(x)] = seam ? 2 : 1;
    MapTexel t{};
    if (which.diffuse) t.diffuse = sample_bilinear(maps.diffuse, uv);
    if (which.roughness) t.roughness = sample_bilinear(maps.roughness, uv).x();
    if (which.specular) t.specular = sample_bilinear(maps.specular, uv).x();
    if (!which.normal) return t;
    // Normal: scan tangent space -> world -> template tangent space.
    const Eigen::Vector3f stored = sample_bilinear(maps.normal, uv);
    const Eigen::Vector3f n_scan = (2 * stored - Eigen::Vector3f::Ones()).normalized();
    const Eigen::Vector3f world = tangent_frame(source, source_tangents, s.face, s.barycentric.cast<float>()) * n_scan;
    t.normal = (tangent_frame(target, target_tangents, f, b).transpose() * world).normalized();
    return t;
  }, progress, which);
  return result;
}

TransferErrors compare_maps(const std::string& transferred_dir, const std::string& truth_dir,
                            const std::vector<uint8_t>& texel_class) {
  TransferErrors e;
  const std::string d_path = find_scan_map(transferred_dir, "diffuse"), n_path = find_scan_map(transferred_dir, "normal");
  const std::string dt_path = find_scan_map(truth_dir, "diffuse"), nt_path = find_scan_map(truth_dir, "normal");
  e.has_diffuse = !d_path.empty() && !dt_path.empty();
  e.has_normal = !n_path.empty() && !nt_path.empty();
  const auto same_size = [&](const Image& a, const Image& b) {
    if (a.width != b.width || a.height != b.height || size_t(a.width) * size_t(a.height) != texel_class.size()) {
      throw InvalidInput(truth_dir, "truth maps differ in size from the transferred maps",
                         "make them at the same resolution (scan synth --truth-res = register --maps-res)");
    }
  };
  const auto inside = [&](size_t i) { return texel_class[i] == 1; };
  if (e.has_diffuse) {
    const Image d = read_image(d_path), dt = read_image(dt_path);
    same_size(d, dt);
    const Image ds = d.color_space == ColorSpace::sRGB ? d : to_srgb(d), dts = dt.color_space == ColorSpace::sRGB ? dt : to_srgb(dt);
    double squared = 0;
    int64_t texels = 0;
    for (int y = 0; y < d.height; ++y)
      for (int x = 0; x < d.width; ++x) {
        if (!inside(size_t(y) * size_t(d.width) + size_t(x))) continue;
        for (int k = 0; k < 3; ++k) squared += std::pow(double(ds.at(x, y, k)) - dts.at(x, y, k), 2);
        ++texels;
      }
    const double mse = texels ? squared / double(3 * texels) : 0;
    e.diffuse_psnr_db = mse > 0 ? 10 * std::log10(1.0 / mse) : 99;
    e.texels = texels;
  }
  if (e.has_normal) {
    const Image n = read_image(n_path, ColorSpace::Data), nt = read_image(nt_path, ColorSpace::Data);
    same_size(n, nt);
    std::vector<double> angles;
    for (int y = 0; y < n.height; ++y)
      for (int x = 0; x < n.width; ++x) {
        if (!inside(size_t(y) * size_t(n.width) + size_t(x))) continue;
        Eigen::Vector3d a, b;
        for (int k = 0; k < 3; ++k) {
          a[k] = 2.0 * n.at(x, y, k) - 1;
          b[k] = 2.0 * nt.at(x, y, k) - 1;
        }
        angles.push_back(std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI);
      }
    e.texels = int64_t(angles.size());
    if (!angles.empty()) {
      e.normal_median_deg = quantile(angles, 0.5);
      e.normal_p95_deg = quantile(angles, 0.95);
    }
  }
  return e;
}

}  // namespace bareskin
