#include "scan/colmap.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <tuple>
#include <sstream>
#include <thread>
#include <cstdio>

#include "core/error.h"
#include "core/image_io.h"
#include "template/surface.h"

namespace bareskin {
namespace fs = std::filesystem;
namespace {

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

std::string database_summary(const std::string& work);

}  // namespace

void ColmapOptions::check() const {
  if (threads < 0) throw InvalidInput("--threads", "must not be negative", "0 uses every core");
  if (max_features < 100 || max_features > 100000)
    throw InvalidInput("--colmap-features", std::to_string(max_features) + " SIFT features is outside [100, 100000]",
                       "use e.g. 8192 (default)");
  if (max_image_size < 64) throw InvalidInput("COLMAP's image size", "must be at least 64 px", "use e.g. 3200 (default)");
  if (!(peak_threshold >= 0.0001 && peak_threshold <= 0.1))
    throw InvalidInput("--colmap-peak", "the SIFT peak threshold must lie in [0.0001, 0.1]", "use e.g. 0.0067 (default)");
  if (init_min_inliers < 1) throw InvalidInput("COLMAP's initial inliers", "must be at least 1", "use e.g. 100 (default)");
  if (!(focal_px >= 0 && focal_px < 1e7))
    throw InvalidInput("--colmap-focal", "the focal length must be a positive number of px", "or leave it out");
}

ColmapModel run_colmap(const std::string& images, const std::string& work, const ColmapOptions& o,
                       const std::string& log) {
  o.check();
  if (std::system("command -v colmap > /dev/null 2>&1") != 0)
    throw IoError("colmap", "is not installed", "install Debian's colmap package (make deps)");
  fs::create_directories(work + "/sparse");
  const std::string db = shell_quote(work + "/database.db"), img = shell_quote(images), out = " >> " + shell_quote(log) + " 2>&1";
  const std::string t = std::to_string(o.threads > 0 ? o.threads : std::max(1u, std::thread::hardware_concurrency()));
  std::ostringstream sift;
  sift << " --SiftExtraction.max_num_features " << o.max_features << " --SiftExtraction.max_image_size "
       << o.max_image_size << " --SiftExtraction.peak_threshold " << o.peak_threshold
       << " --SiftExtraction.domain_size_pooling " << int(o.domain_size_pooling);
  if (o.focal_px > 0) {  // SIMPLE_PINHOLE's f, cx, cy, from the first photo's size
    for (const auto& e : fs::directory_iterator(images)) {
      const std::string ext = e.path().extension().string();
      if (ext != ".png" && ext != ".jpg" && ext != ".jpeg" && ext != ".tif" && ext != ".tiff" && ext != ".PNG" && ext != ".JPG")
        continue;
      const Image first = read_image(e.path().string());
      sift << " --ImageReader.camera_params " << o.focal_px << "," << first.width / 2.0 << "," << first.height / 2.0;
      break;
    }
  }
  const std::vector<std::string> steps = {
      "colmap feature_extractor --database_path " + db + " --image_path " + img +
          " --ImageReader.camera_model SIMPLE_PINHOLE --ImageReader.single_camera 1 --SiftExtraction.use_gpu 0"
          " --SiftExtraction.num_threads " + t + sift.str(),
      "colmap exhaustive_matcher --database_path " + db + " --SiftMatching.use_gpu 0 --SiftMatching.num_threads " + t,
      "colmap mapper --database_path " + db + " --image_path " + img + " --output_path " +
          shell_quote(work + "/sparse") + " --Mapper.num_threads " + t + " --Mapper.init_min_num_inliers " +
          std::to_string(o.init_min_inliers) + (o.focal_px > 0 ? " --Mapper.ba_refine_focal_length 0" : ""),
  };
  for (const std::string& step : steps)
    if (std::system((step + out).c_str()) != 0)
      throw InvalidInput(images, "COLMAP failed at '" + step.substr(7, step.find(' ', 7) - 7) + "'" +
                                     database_summary(work), "see " + log);
  // The largest model (most registered images).
  ColmapModel best;
  for (const auto& e : fs::directory_iterator(work + "/sparse")) {
    if (!e.is_directory()) continue;
    const std::string txt = e.path().string() + "_txt";
    fs::create_directories(txt);
    const std::string cmd = "colmap model_converter --input_path " + shell_quote(e.path().string()) +
                            " --output_path " + shell_quote(txt) + " --output_type TXT" + out;
    if (std::system(cmd.c_str()) != 0) continue;
    ColmapModel m = read_colmap_text_model(txt);
    if (m.images.size() > best.images.size()) best = std::move(m);
  }
  std::tie(best.median_features, best.verified_pairs) = colmap_database_stats(work);
  if (best.images.empty())
    throw InvalidInput(images, "COLMAP reconstructed no model from these photos" + database_summary(work),
                       "see " + log);
  return best;
}

std::pair<long, long> colmap_database_stats(const std::string& work) {
  const std::string db = work + "/database.db";
  if (!fs::exists(db) || std::system("command -v sqlite3 > /dev/null 2>&1") != 0) return {-1, -1};
  const std::string cmd = "sqlite3 -batch " + shell_quote(db) +
                          " 'select rows from keypoints order by rows; select -1; "
                          "select count(*) from two_view_geometries where rows >= 15;' 2> /dev/null";
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return {-1, -1};
  std::vector<long> features;
  long pairs = -1;
  bool after = false;
  for (long v; std::fscanf(pipe, "%ld", &v) == 1;) {
    if (v == -1 && !after) after = true;
    else if (after) pairs = v;
    else features.push_back(v);
  }
  pclose(pipe);
  if (features.empty() || pairs < 0) return {-1, -1};
  return {features[features.size() / 2], pairs};
}

namespace {
std::string database_summary(const std::string& work) {
  const auto [features, pairs] = colmap_database_stats(work);
  if (features < 0) return "";
  return " (median " + std::to_string(features) + " SIFT features per photo, " + std::to_string(pairs) +
         " photo pairs with 15+ verified matches)";
}
}  // namespace

Similarity similarity_from_points(const Eigen::MatrixX3d& from, const Eigen::MatrixX3d& to) {
  std::vector<Eigen::Index> rows;
  for (Eigen::Index i = 0; i < std::min(from.rows(), to.rows()); ++i)
    if (from.row(i).allFinite() && to.row(i).allFinite()) rows.push_back(i);
  if (rows.size() < 4) throw InvalidInput("", "fewer than 4 corresponding points to align", "check the detections");
  Eigen::Matrix3Xd a(3, rows.size()), b(3, rows.size());
  for (size_t k = 0; k < rows.size(); ++k) a.col(k) = from.row(rows[k]).transpose(), b.col(k) = to.row(rows[k]).transpose();
  const Eigen::Matrix4d T = Eigen::umeyama(a, b, true);
  Similarity S;
  S.s = std::cbrt(T.block<3, 3>(0, 0).determinant());
  S.R = T.block<3, 3>(0, 0) / S.s;
  S.t = T.block<3, 1>(0, 3);
  return S;
}

Similarity align_points_to_mesh(const Eigen::MatrixX3d& points, const Mesh& mesh, Similarity S, int iterations,
                                double trim, double* rms_mm) {
  const SurfaceLocator locator(mesh.V, mesh.F);
  const Eigen::Index n = points.rows();
  double rms = 0;
  for (int it = 0; it < iterations && n >= 4; ++it) {
    Eigen::MatrixX3d from(n, 3), to(n, 3);
    std::vector<std::pair<double, Eigen::Index>> dist;
    for (Eigen::Index i = 0; i < n; ++i) {
      from.row(i) = points.row(i);
      const Eigen::Vector3d x = S.apply(points.row(i).transpose());
      to.row(i) = locator.locate(x).point.transpose();
      dist.emplace_back((to.row(i).transpose() - x).squaredNorm(), i);
    }
    std::sort(dist.begin(), dist.end());
    const size_t keep = std::max<size_t>(4, size_t(double(n) * (1 - trim)));
    Eigen::MatrixX3d f(keep, 3), t(keep, 3);
    rms = 0;
    for (size_t k = 0; k < keep; ++k) f.row(Eigen::Index(k)) = from.row(dist[k].second), t.row(Eigen::Index(k)) = to.row(dist[k].second), rms += dist[k].first;
    rms = std::sqrt(rms / double(keep));
    S = similarity_from_points(f, t);
  }
  if (rms_mm) *rms_mm = rms;
  return S;
}

Eigen::MatrixX3d points_near_mesh(const Eigen::MatrixX3d& points, const Mesh& mesh, const Similarity& S,
                                  double max_mm) {
  const SurfaceLocator locator(mesh.V, mesh.F);
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    const Eigen::Vector3d x = S.apply(points.row(i).transpose());
    if ((locator.locate(x).point - x).norm() <= max_mm) keep.push_back(i);
  }
  Eigen::MatrixX3d out(Eigen::Index(keep.size()), 3);
  for (size_t k = 0; k < keep.size(); ++k) out.row(Eigen::Index(k)) = points.row(keep[k]);
  return out;
}

Camera transform_camera(const Camera& c, const Similarity& S) {
  // p = R_c x_model + t_c with x_model = Rᵀ (x − t) / s; scaling p by s keeps its pixels.
  Camera out = c;
  out.R = c.R * S.R.transpose();
  out.t = S.s * c.t - out.R * S.t;
  return out;
}

}  // namespace bareskin
