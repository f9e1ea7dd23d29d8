#include "render/shade.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "core/files.h"
#include "core/parallel.h"
#include "render/rasterize.h"
#include "render/sh.h"

namespace bareskin {

std::array<double, 27> default_lighting() {
  std::array<double, 27> g{};
  for (int c = 0; c < 3; ++c) {
    g[size_t(9 * c)] = kDeep3dAmbient;
    g[size_t(9 * c + 1)] = -0.12;  // basis 1 is -y: light from above
    g[size_t(9 * c + 2)] = 0.2;    // basis 2 is z: light from the camera's side
  }
  return g;
}

Frame Frame::blank(int W, int H) {
  Frame f;
  f.colour = Image(W, H, 3, ColorSpace::Linear);
  f.albedo = Image(W, H, 3, ColorSpace::Linear);
  f.depth = Image(W, H, 1, ColorSpace::Data);
  f.normal = Image(W, H, 3, ColorSpace::Data);
  f.mask = Image(W, H, 1, ColorSpace::Data);
  return f;
}

void ShadeOptions::check() const {
  if (!albedo.allFinite() || albedo.minCoeff() < 0)
    throw InvalidInput("", "the albedo must be finite and >= 0 (linear RGB)", "e.g. 0.6 0.6 0.6");
  for (double g : gamma)
    if (!std::isfinite(g)) throw InvalidInput("", "the SH lighting has a non-finite coefficient", "give 27 finite numbers");
}

Frame render_frame(const Mesh& mesh, const Camera& camera, const ShadeOptions& options) {
  options.check();
  if (mesh.V.rows() == 0 || mesh.F.rows() == 0) throw InvalidInput("", "the mesh is empty", "give a mesh with triangles");
  if (!mesh.V.allFinite()) throw InvalidInput("", "the mesh has NaN or infinite vertices", "repair the mesh");
  if (options.texture && !mesh.has_uv()) throw InvalidInput("", "a texture needs a mesh with UVs", "");
  const RasterOutput r = rasterize_mesh(mesh, camera, options.cull_back_faces);
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> F = mesh.F;

  const Eigen::MatrixX3d N = mesh.has_normals() ? mesh.N : vertex_normals(mesh.V, mesh.F);
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> Nc = (N * camera.R.transpose()).cast<float>();
  const std::vector<float> normal = interpolate(r, F.data(), Nc.data(), 3);
  std::vector<float> uv;
  if (options.texture) {
    const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> FUV = mesh.FUV;
    const Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor> UV = mesh.UV.cast<float>();
    uv = interpolate(r, FUV.data(), UV.data(), 2);
  }
  const int W = camera.width, H = camera.height;
  Frame out = Frame::blank(W, H);
  out.dropped_behind = r.dropped_behind;
  parallel_for(0, int64_t(W) * H, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      if (r.triangle[size_t(i)] < 0) continue;
      const Eigen::Vector3d n = Eigen::Vector3d(normal[3 * size_t(i)], normal[3 * size_t(i) + 1], normal[3 * size_t(i) + 2]).normalized();
      const Eigen::Vector3f a = options.texture
                                    ? sample_bilinear(*options.texture, {uv[2 * size_t(i)], uv[2 * size_t(i) + 1]})
                                    : options.albedo;
      const Eigen::Vector3d e = sh_irradiance(n, options.gamma.data());
      for (int c = 0; c < 3; ++c) {
        out.albedo.pixels[3 * size_t(i) + size_t(c)] = a[c];
        out.colour.pixels[3 * size_t(i) + size_t(c)] = float(a[c] * e[c]);
        out.normal.pixels[3 * size_t(i) + size_t(c)] = float(0.5 * (n[c] + 1));
      }
      out.depth.pixels[size_t(i)] = r.depth[size_t(i)];
      out.mask.pixels[size_t(i)] = 1;
    }
  }, 4096);
  return out;
}

std::array<double, 27> read_sh_lighting(const std::string& sh) {
  if (sh == "default") return default_lighting();
  std::array<double, 27> g{};
  if (sh == "none") {
    for (int c = 0; c < 3; ++c) g[size_t(9 * c)] = kDeep3dAmbient;
    return g;
  }
  const auto doc = nlohmann::json::parse(read_file(sh), nullptr, false);
  if (doc.is_discarded() || !doc.is_array() || doc.size() != 27) {
    throw InvalidInput(sh, "is not a JSON list of 27 numbers", "give 9 SH coefficients per RGB channel, channel-major");
  }
  for (size_t k = 0; k < 27; ++k) {
    if (!doc[k].is_number() || !std::isfinite(doc[k].get<double>())) {
      throw InvalidInput(sh, "coefficient " + std::to_string(k) + " is not a finite number", "");
    }
    g[k] = doc[k].get<double>();
  }
  return g;
}

Image pass_image(const Frame& frame, const std::string& pass, bool exr) {
  Image img = pass == "colour" ? frame.colour : pass == "albedo" ? frame.albedo : pass == "normal" ? frame.normal
                                                : pass == "mask" ? frame.mask : frame.depth;
  if (pass == "depth" && !exr) {  // nearer brighter, over the covered range
    float lo = 1e30f, hi = -1e30f;
    for (size_t i = 0; i < img.pixels.size(); ++i)
      if (frame.mask.pixels[i] > 0) lo = std::min(lo, img.pixels[i]), hi = std::max(hi, img.pixels[i]);
    for (size_t i = 0; i < img.pixels.size(); ++i)
      img.pixels[i] = frame.mask.pixels[i] > 0 ? 1 - 0.8f * (img.pixels[i] - lo) / std::max(hi - lo, 1e-6f) : 0;
  }
  if ((pass == "colour" || pass == "albedo") && !exr) img = to_srgb(img);
  return img;
}

}  // namespace bareskin
