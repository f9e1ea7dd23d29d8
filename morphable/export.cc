#include "morphable/export.h"

#include <algorithm>

#include "core/files.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/mesh_io.h"

namespace bareskin {
namespace {

// An R x R linear RGB appearance (row-major floats) as an sRGB PNG; texels outside the mask grey.
void write_appearance(const std::string& path, const std::vector<float>& rgb, const MorphableModel& m) {
  const int R = m.appearance_resolution;
  Image img(R, R, 3, ColorSpace::Linear, 0.2f);
  for (size_t p = 0; p < m.appearance_mask.size(); ++p) {
    if (!m.appearance_mask[p]) continue;
    for (int c = 0; c < 3; ++c) img.pixels[3 * p + size_t(c)] = std::clamp(rgb[3 * p + size_t(c)], 0.f, 1.f);
  }
  write_image(path, to_srgb(img));
}

}  // namespace

void export_model_previews(const std::string& dir, const MorphableModel& m) {
  make_directories(dir);
  const auto write = [&](const std::string& name, const Eigen::MatrixX3d& V) {
    Mesh mesh = m.topology;
    mesh.V = V;
    mesh.N = vertex_normals(V, mesh.F);
    write_mesh(dir + "/" + name + ".obj", mesh);
  };
  write("mean", m.topology.V);
  for (int k = 0; k < std::min<int>(3, int(m.shape_basis.rows())); ++k) {
    for (double s : {-3.0, 3.0}) {
      Eigen::VectorXd alpha = Eigen::VectorXd::Zero(k + 1);
      alpha(k) = s;
      write(fmt::format("shape{}_{}3sd", k + 1, s < 0 ? "minus" : "plus"), m.shape(alpha));
    }
  }
  for (int k = 0; k < std::min<int>(2, int(m.expression_basis.rows())); ++k) {
    Eigen::VectorXd beta = Eigen::VectorXd::Zero(k + 1);
    beta(k) = 3;
    write(fmt::format("expression{}_plus3sd", k + 1), m.shape(Eigen::VectorXd(), beta));
  }
  if (m.appearance_resolution > 0 && !m.appearance_mask.empty()) {
    write_appearance(dir + "/appearance_mean.png", m.appearance(Eigen::VectorXd()), m);
    for (int k = 0; k < std::min<int>(2, int(m.appearance_basis.rows())); ++k) {
      for (double s : {-3.0, 3.0}) {
        Eigen::VectorXd delta = Eigen::VectorXd::Zero(k + 1);
        delta(k) = s;
        write_appearance(dir + fmt::format("/appearance{}_{}3sd.png", k + 1, s < 0 ? "minus" : "plus"), m.appearance(delta), m);
      }
    }
  }
}

}  // namespace bareskin
