#include "scan/synth.h"

#include <Eigen/Geometry>
#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/safetensors.h"
#include "morphable/surface.h"

namespace bareskin {

void SynthOptions::check() const {
  if (count < 1 || count > 100000) throw InvalidInput("", "--count must lie in [1, 100000]", "");
  if (scan_vertices < 1000 || scan_vertices > 5000000) throw InvalidInput("", "--vertices must lie in [1000, 5000000]", "");
  if (remesh_iterations < 1 || remesh_iterations > 10) throw InvalidInput("", "--remesh-iterations must lie in [1, 10]", "");
  identity.check();
  if (!(noise_mm >= 0 && noise_mm <= 5)) throw InvalidInput("", "--noise must lie in [0, 5] mm", "");
  if (!(scale_jitter >= 0 && scale_jitter < 0.5)) throw InvalidInput("", "--scale-jitter must lie in [0, 0.5)", "");
  if (!(rotation_jitter_deg >= 0 && rotation_jitter_deg <= 180)) throw InvalidInput("", "--rotation-jitter must lie in [0, 180] degrees", "");
  if (!(translation_jitter_mm >= 0 && translation_jitter_mm <= 1000)) throw InvalidInput("", "--translation-jitter must lie in [0, 1000] mm", "");
}

uint64_t subject_seed(uint64_t population_seed, int index) {
  // splitmix64 of (seed, index): independent streams, the same whatever the count or the order of generation.
  uint64_t z = population_seed + 0x9e3779b97f4a7c15ull * uint64_t(index + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

SyntheticScan synthesize_scan(const TemplateFace& face, int index, const SynthOptions& options) {
  options.check();
  SyntheticScan scan;
  char id[32];
  std::snprintf(id, sizeof id, "subject_%04d", index);
  scan.id = id;
  scan.identity = sample_identity(face, subject_seed(options.seed, index), options.identity);
  const Eigen::MatrixX3d deformed = face.mesh.V + scan.identity.displacement;

  isotropic_remesh(deformed, face.mesh.F, options.scan_vertices, options.remesh_iterations, scan.mesh.V, scan.mesh.F);
  scan.mesh.N = vertex_normals(scan.mesh.V, scan.mesh.F);

  // Each deformed template vertex lies on the smooth deformed surface; its truth is the closest point of the scan.
  const SurfaceLocator locator(scan.mesh.V, scan.mesh.F);
  const Eigen::Index n = deformed.rows();
  scan.truth_face.resize(n);
  scan.truth_barycentric.resize(n, 3);
  scan.truth_point.resize(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const SurfacePoint p = locator.locate(deformed.row(i).transpose());
    scan.truth_face(i) = p.face;
    scan.truth_barycentric.row(i) = p.barycentric.transpose();
    scan.truth_point.row(i) = p.point.transpose();
  }
  // Realism knobs, from a stream of their own so that turning them on leaves the identity unchanged.
  std::mt19937_64 rng(subject_seed(options.seed ^ 0x5ca1ab1eull, index));
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  if (options.noise_mm > 0) {
    for (Eigen::Index i = 0; i < scan.mesh.V.rows(); ++i) scan.mesh.V.row(i) += options.noise_mm * normal(rng) * scan.mesh.N.row(i);
  }
  if (options.scale_jitter > 0 || options.rotation_jitter_deg > 0 || options.translation_jitter_mm > 0) {
    scan.scale = 1.0 + options.scale_jitter * uniform(rng);
    const Eigen::Vector3d axis = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
    scan.rotation = Eigen::AngleAxisd(options.rotation_jitter_deg * M_PI / 180.0 * uniform(rng), axis).toRotationMatrix();
    for (int k = 0; k < 3; ++k) scan.translation[k] = options.translation_jitter_mm * uniform(rng);
    scan.mesh.V = ((scan.scale * scan.mesh.V * scan.rotation.transpose()).rowwise() + scan.translation.transpose()).eval();
  }
  if (options.noise_mm > 0 || scan.scale != 1 || !scan.rotation.isIdentity() || !scan.translation.isZero()) {
    // The truth keeps its face and barycentrics; its point follows the moved vertices, so it stays on the scan.
    for (Eigen::Index i = 0; i < n; ++i) {
      const int f = scan.truth_face(i);
      scan.truth_point.row(i) = scan.truth_barycentric(i, 0) * scan.mesh.V.row(scan.mesh.F(f, 0)) +
                                scan.truth_barycentric(i, 1) * scan.mesh.V.row(scan.mesh.F(f, 1)) +
                                scan.truth_barycentric(i, 2) * scan.mesh.V.row(scan.mesh.F(f, 2));
    }
    scan.mesh.N = vertex_normals(scan.mesh.V, scan.mesh.F);
  }
  scan.landmarks.units = "mm";
  scan.landmarks.points.resize(68, 3);
  for (int k = 0; k < 68; ++k) scan.landmarks.points.row(k) = scan.truth_point.row(face.landmark_vertices[size_t(k)]);
  return scan;
}

void write_scan(const std::string& dir, const SyntheticScan& scan, const SynthOptions& options) {
  AtomicDirectory out(dir + "/" + scan.id);
  write_mesh(out.path() + "/mesh.ply", scan.mesh);
  write_landmarks(out.path() + "/landmarks.json", scan.landmarks);
  make_directories(out.path() + "/truth");

  SafeTensorsWriter truth;
  const int64_t n = scan.truth_point.rows();
  std::vector<float> points(size_t(n) * 3), bary(size_t(n) * 3), displacement(size_t(n) * 3);
  std::vector<int32_t> faces(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i) {
    faces[size_t(i)] = scan.truth_face(i);
    for (int k = 0; k < 3; ++k) {
      points[size_t(3 * i + k)] = float(scan.truth_point(i, k));
      bary[size_t(3 * i + k)] = float(scan.truth_barycentric(i, k));
      displacement[size_t(3 * i + k)] = float(scan.identity.displacement(i, k));
    }
  }
  truth.add("template_to_scan_point", {n, 3}, points);
  truth.add("template_to_scan_face", {n}, faces);
  truth.add("template_to_scan_barycentric", {n, 3}, bary);
  truth.add("identity_displacement", {n, 3}, displacement);
  truth.set_metadata("format", "bareskin.scan_truth");
  truth.set_metadata("format_version", "1");
  truth.set_metadata("units", "mm");
  truth.set_metadata("subject", scan.id);
  truth.write(out.path() + "/truth/correspondence.safetensors");

  nlohmann::json params;
  params["subject"] = scan.id;
  params["seed"] = scan.identity.seed;
  params["population_seed"] = options.seed;
  params["features"] = scan.identity.features;
  params["gp_lengths_mm"] = options.identity.gp_lengths;
  params["gp_sigmas_mm"] = options.identity.gp_sigmas;
  params["fourier_features"] = options.identity.fourier_features;
  params["symmetry"] = options.identity.symmetry;
  params["scan_vertices"] = scan.mesh.V.rows();
  params["scan_triangles"] = scan.mesh.F.rows();
  params["noise_mm"] = options.noise_mm;
  params["similarity"] = {{"scale", scan.scale},
                          {"rotation", {{scan.rotation(0, 0), scan.rotation(0, 1), scan.rotation(0, 2)},
                                        {scan.rotation(1, 0), scan.rotation(1, 1), scan.rotation(1, 2)},
                                        {scan.rotation(2, 0), scan.rotation(2, 1), scan.rotation(2, 2)}}},
                          {"translation", {scan.translation.x(), scan.translation.y(), scan.translation.z()}},
                          {"meaning", "x_scan = scale * rotation * x_identity + translation"}};
  write_file_atomic(out.path() + "/truth/identity.json", params.dump(1) + "\n");
  out.commit();
}

}  // namespace bareskin
