#include "morphable/build.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <atomic>
#include <chrono>
#include <filesystem>

#include "core/error.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/mesh_io.h"
#include "core/parallel.h"
#include "morphable/pca.h"
#include "morphable/procrustes.h"
#include "render/rasterize.h"

namespace bareskin {
namespace {

namespace fs = std::filesystem;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// dir/<stem><ext> for the first extension that exists, or "".
std::string find_file(const std::string& dir, const std::string& stem, std::initializer_list<const char*> extensions) {
  for (const char* ext : extensions)
    if (fs::exists(dir + "/" + stem + ext)) return dir + "/" + stem + ext;
  return "";
}

// Component count: the asked one, clamped to what the data allows (with a note) or refused.
int settle(int asked, int available, const char* what, bool exact, BuildReport& report) {
  if (asked <= available) return asked;
  const std::string line = std::string(what) + ": " + std::to_string(asked) + " components asked, the data gives " +
                           std::to_string(available);
  if (exact) throw InvalidInput("", line, "ask for at most " + std::to_string(available));
  report.notes.push_back(line + "; using " + std::to_string(available));
  spdlog::info("mm-build: {}", report.notes.back());
  return available;
}

RowMatrixXf to_float(const Eigen::MatrixXd& M) { return M.cast<float>(); }

}  // namespace

void BuildOptions::check() const {
  if (shape_components < 1) throw InvalidInput("", "--shape-components must be >= 1", "");
  if (!(shape_variance >= 0 && shape_variance <= 1)) throw InvalidInput("", "--shape-variance must lie in [0, 1]", "");
  if (appearance_components < 0 || expression_components < 0) {
    throw InvalidInput("", "component counts must be >= 0", "");
  }
  if (appearance_resolution < 8 || appearance_resolution > 4096) {
    throw InvalidInput("", "--appearance-res must lie in [8, 4096]", "");
  }
}

std::vector<uint8_t> face_regions(const TemplateFace& face, std::vector<std::string>& names) {
  names = {"forehead", "brows", "eyes", "nose", "mouth", "cheeks_jaw"};
  const auto group = [](int landmark) -> uint8_t {
    if (landmark <= 16) return 5;
    if (landmark <= 26) return 1;
    if (landmark <= 35) return 3;
    if (landmark <= 47) return 2;
    return 4;
  };
  if (face.landmark_vertices.size() != 68) throw InvalidInput("template", "needs 68 landmark vertices", "");
  double brow_y = 0;
  for (int k = 17; k <= 26; ++k) brow_y += face.mesh.V(face.landmark_vertices[size_t(k)], 1) / 10;
  std::vector<uint8_t> region(size_t(face.mesh.V.rows()));
  parallel_for(0, face.mesh.V.rows(), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      int best = 0;
      double best_d = 1e300;
      for (int k = 0; k < 68; ++k) {
        const double d = (face.mesh.V.row(i) - face.mesh.V.row(face.landmark_vertices[size_t(k)])).squaredNorm();
        if (d < best_d) best_d = d, best = k;
      }
      uint8_t g = group(best);
      if ((g == 1 && face.mesh.V(i, 1) > brow_y + 8) || (g == 5 && face.mesh.V(i, 1) > brow_y)) g = 0;
      region[size_t(i)] = g;
    }
  }, 1024);
  return region;
}

std::vector<uint8_t> uv_mask(const Mesh& mesh, int R) {
  if (!mesh.has_uv()) throw InvalidInput("template", "has no UVs", "use a template with UVs");
  const RasterOutput uv = rasterize_uv(mesh, R);
  std::vector<uint8_t> mask(uv.triangle.size());
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = uv.triangle[i] >= 0;
  return mask;
}

RowMatrixXf read_shapes(const TemplateFace& face, const std::vector<std::string>& dirs, const ProgressCallback& progress) {
  const Eigen::Index V = face.mesh.V.rows();
  RowMatrixXf X(Eigen::Index(dirs.size()), 3 * V);
  std::atomic<int64_t> done{0};
  parallel_for(0, int64_t(dirs.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const std::string path = find_file(dirs[size_t(i)], "mesh", {".ply", ".obj"});
      if (path.empty()) throw InvalidInput(dirs[size_t(i)], "has no mesh.ply or mesh.obj", "run 'bareskin scan register' first");
      const Mesh m = read_mesh(path);
      if (m.V.rows() != V) {
        throw InvalidInput(path, "has " + std::to_string(m.V.rows()) + " vertices, the template " + std::to_string(V),
                           "register every scan with the same template");
      }
      if (m.F != face.mesh.F) {
        throw InvalidInput(path, "has a different triangle list from the template's",
                           "register every scan with the same template");
      }
      const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> v = m.V.cast<float>();
      X.row(i) = Eigen::Map<const Eigen::RowVectorXf>(v.data(), 3 * V);
      report(progress, ++done, int64_t(dirs.size()), "reading shapes");
    }
  }, 1);
  return X;
}

namespace {

// The appearance model: diffuse maps in the template UV, linear light, box-filtered to R x R, texels inside the layout
// only, PCA over the subjects that have a map (the others are listed in the report: photogrammetry scans may bring
// geometry alone). Fewer than two such subjects: no appearance model (InvalidInput when a count was asked for).
void build_appearance(const TemplateFace& face, const std::vector<std::string>& dirs, const BuildOptions& options,
                      MorphableModel& model, BuildReport& report, const ProgressCallback& progress) {
  const int R = options.appearance_resolution;
  model.appearance_resolution = R;
  model.appearance_mask = uv_mask(face.mesh, R);
  model.appearance_mean = Eigen::VectorXf::Zero(3 * R * R);
  model.appearance_basis.resize(0, 3 * R * R);
  if (options.appearance_components == 0) return;
  auto t = std::chrono::steady_clock::now();
  std::vector<std::string> maps;
  for (const std::string& d : dirs) {
    const std::string path = find_file(d, "diffuse", {".png", ".tif", ".tiff", ".exr"});
    if (path.empty()) report.subjects_without_diffuse.push_back(fs::path(d).filename().string());
    else maps.push_back(path);
  }
  const int m = int(maps.size());
  if (m < 2) {
    const std::string line = "appearance: " + std::to_string(m) + " of " + std::to_string(dirs.size()) +
                             " subjects have a diffuse map; an appearance model needs at least 2";
    if (options.exact.appearance) throw InvalidInput("", line, "register scans that have diffuse maps, or --appearance-components 0");
    report.notes.push_back(line + "; the model has none");
    spdlog::warn("mm-build: {}", report.notes.back());
    return;
  }
  if (!report.subjects_without_diffuse.empty()) {
    std::string names;
    for (const std::string& s : report.subjects_without_diffuse) names += (names.empty() ? "" : ", ") + s;
    report.notes.push_back("appearance: " + std::to_string(report.subjects_without_diffuse.size()) + " of " +
                           std::to_string(dirs.size()) + " subjects have no diffuse map (" + names +
                           "); the appearance model is built from the other " + std::to_string(m));
    spdlog::warn("mm-build: {}", report.notes.back());
  }
  std::vector<int64_t> texels;
  for (size_t p = 0; p < model.appearance_mask.size(); ++p)
    if (model.appearance_mask[p]) texels.push_back(int64_t(p));
  RowMatrixXf A(m, 3 * Eigen::Index(texels.size()));
  std::atomic<int64_t> done{0};
  parallel_for(0, m, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const std::string& path = maps[size_t(i)];
      Image img = read_image(path);
      if (img.color_space == ColorSpace::sRGB) img = to_linear(img);
      if (img.width != img.height || img.width % R != 0 || img.channels < 3) {
        throw InvalidInput(path, "is " + std::to_string(img.width) + "x" + std::to_string(img.height) + "x" +
                                     std::to_string(img.channels) + "; the appearance model needs square RGB maps "
                                     "whose size is a multiple of " + std::to_string(R),
                           "choose --appearance-res dividing the map size");
      }
      const int f = img.width / R;
      for (size_t k = 0; k < texels.size(); ++k) {
        const int x = int(texels[k] % R), y = int(texels[k] / R);
        for (int c = 0; c < 3; ++c) {
          double sum = 0;
          for (int dy = 0; dy < f; ++dy)
            for (int dx = 0; dx < f; ++dx) sum += img.at(x * f + dx, y * f + dy, c);
          A(i, Eigen::Index(3 * k) + c) = float(sum / (f * f));
        }
      }
      if (!A.row(i).allFinite()) throw InvalidInput(path, "holds NaN or Inf", "re-transfer the maps");
      bareskin::report(progress, ++done, m, "reading maps");
    }
  }, 1);
  report.seconds_read_maps = seconds_since(t);
  t = std::chrono::steady_clock::now();
  const int k = settle(options.appearance_components, m - 1, "appearance", options.exact.appearance, report);
  const Pca appearance = pca(A, k, 0, "appearance");
  model.appearance_basis = RowMatrixXf::Zero(k, 3 * R * R);
  for (size_t q = 0; q < texels.size(); ++q)
    for (int c = 0; c < 3; ++c) {
      model.appearance_mean(3 * texels[q] + c) = float(appearance.mean(Eigen::Index(3 * q) + c));
      model.appearance_basis.col(3 * texels[q] + c) = appearance.basis.col(Eigen::Index(3 * q) + c).cast<float>();
    }
  model.appearance_stddev = appearance.variance.cwiseSqrt().cast<float>();
  report.appearance_subjects = m;
  report.appearance_variance_explained = appearance.variance.sum() / appearance.total_variance;
  report.seconds_appearance_pca = seconds_since(t);
}

}  // namespace

MorphableModel build_model(const TemplateFace& face, const std::vector<std::string>& dirs,
                           const std::vector<NamedShape>& blendshapes, const BuildOptions& options, BuildReport& report,
                           const ProgressCallback& progress) {
  options.check();
  const int n = int(dirs.size());
  if (n < 3) {
    throw InvalidInput("", "a morphable model needs at least 3 subjects, got " + std::to_string(n), "add subjects");
  }
  report.subjects = n;
  MorphableModel model;
  for (const std::string& d : dirs) model.subjects.push_back(fs::path(d).filename().string());

  // Shape: read, align (GPA), PCA.
  auto t = std::chrono::steady_clock::now();
  RowMatrixXf X = read_shapes(face, dirs, progress);
  report.seconds_read_shapes = seconds_since(t);
  t = std::chrono::steady_clock::now();
  GpaOptions gpa;
  gpa.scale = options.procrustes_scale;
  const GpaResult aligned = generalized_procrustes(X, face.mesh.V, gpa);
  model.procrustes = aligned.transforms;
  report.gpa_iterations = aligned.iterations;
  report.seconds_gpa = seconds_since(t);
  t = std::chrono::steady_clock::now();
  const int shape_k = settle(options.shape_components, n - 1, "shape", options.exact.shape, report);
  const Pca shape = pca(X, shape_k, options.shape_variance, "shape");
  model.topology = face.mesh;
  model.topology.N.resize(0, 3);
  model.topology.V = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(shape.mean.data(),
                                                                                                 face.mesh.V.rows(), 3);
  model.shape_basis = to_float(shape.basis);
  model.shape_stddev = shape.variance.cwiseSqrt().cast<float>();
  report.shape_variance_explained = shape.variance.sum() / shape.total_variance;
  report.seconds_shape_pca = seconds_since(t);
  X.resize(0, 0);

  // Appearance: from the subjects that have a diffuse map.
  build_appearance(face, dirs, options, model, report, progress);

  // Expression: each blendshape's deltas turned by the rotation taking the template's normal to the mean's at that
  // vertex (the mean identity's local frame), then an orthonormal basis by SVD (through the K x K Gram matrix); the
  // standard deviation of a component is its singular value / sqrt(K), the RMS over the blendshapes.
  t = std::chrono::steady_clock::now();
  const Eigen::Index V = face.mesh.V.rows();
  if (options.expression_components > 0 && !blendshapes.empty()) {
    const Eigen::MatrixX3d Nt = vertex_normals(face.mesh.V, face.mesh.F), Nm = vertex_normals(model.topology.V, face.mesh.F);
    const Eigen::Index K = Eigen::Index(blendshapes.size());
    Eigen::MatrixXd D(3 * V, K);
    for (Eigen::Index b = 0; b < K; ++b) {
      const NamedShape& s = blendshapes[size_t(b)];
      if (s.delta.rows() != V) {
        throw InvalidInput("blendshapes", s.name + " has " + std::to_string(s.delta.rows()) + " vertices, the template " +
                                              std::to_string(V), "give blendshapes made on this template");
      }
      model.expression_names.push_back(s.name);
      for (Eigen::Index i = 0; i < V; ++i) {
        const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Nt.row(i).transpose(), Nm.row(i).transpose());
        D.block<3, 1>(3 * i, b) = q * s.delta.row(i).transpose();
      }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(D.transpose() * D);
    const Eigen::VectorXd lambda = eig.eigenvalues().reverse();
    int rank = 0;
    while (rank < K && lambda(rank) > lambda(0) * 1e-12) ++rank;
    const int k = settle(options.expression_components, rank, "expression", options.exact.expression, report);
    const Eigen::MatrixXd W = eig.eigenvectors().rowwise().reverse().leftCols(k) *
                              lambda.head(k).cwiseSqrt().cwiseInverse().asDiagonal();
    model.expression_basis = to_float((D * W).transpose());
    model.expression_stddev = (lambda.head(k) / double(K)).cwiseSqrt().cast<float>();
  } else {
    model.expression_basis.resize(0, 3 * V);
    model.expression_stddev.resize(0);
  }
  report.seconds_expression = seconds_since(t);

  model.landmark_vertices = face.landmark_vertices;
  model.vertex_region = face_regions(face, model.region_names);
  return model;
}

}  // namespace bareskin
