#include "scan/synth.h"

#include <Eigen/Geometry>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>

#include "core/error.h"
#include "core/files.h"
#include "core/mesh_io.h"
#include "core/parallel.h"
#include "core/safetensors.h"
#include "scan/blendshapes.h"
#include "template/surface.h"

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
  if (!(skin_detail >= 0 && skin_detail <= 1)) throw InvalidInput("", "--skin-detail must lie in [0, 1]", "");
  if (maps.resolution != 0) maps.check();
  if (truth_resolution != 0 && (truth_resolution < 16 || truth_resolution > 32768)) {
    throw InvalidInput("", "--truth-res must be 0 (none) or lie in [16, 32768]", "");
  }
}

namespace {

// Removes the faces not in `keep` and the vertices no longer used; returns the new index of each old face (-1 gone).
std::vector<int> remove_faces(Mesh& mesh, const std::vector<bool>& keep) {
  std::vector<int> face_map(size_t(mesh.F.rows()), -1), vertex_map(size_t(mesh.V.rows()), -1);
  int faces = 0, vertices = 0;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    if (!keep[size_t(f)]) continue;
    face_map[size_t(f)] = faces++;
    for (int k = 0; k < 3; ++k) {
      if (vertex_map[size_t(mesh.F(f, k))] < 0) vertex_map[size_t(mesh.F(f, k))] = vertices++;
    }
  }
  Eigen::MatrixX3d V(vertices, 3);
  Eigen::MatrixX3i F(faces, 3);
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    if (vertex_map[size_t(v)] >= 0) V.row(vertex_map[size_t(v)]) = mesh.V.row(v);
  }
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    if (face_map[size_t(f)] < 0) continue;
    for (int k = 0; k < 3; ++k) F(face_map[size_t(f)], k) = vertex_map[size_t(mesh.F(f, k))];
  }
  mesh.V = std::move(V);
  mesh.F = std::move(F);
  return face_map;
}

// Nostrils: on each side of the columella, the downward-facing faces between subnasale (iBUG 33) and the alar base
// (31 / 35); a disc of radius 2.2 mm around their centroid is cut out.
std::vector<bool> nostril_faces_kept(const Mesh& mesh, const Eigen::MatrixX3d& landmarks) {
  const Eigen::MatrixX3d normals = face_normals(mesh.V, mesh.F);
  std::vector<bool> keep(size_t(mesh.F.rows()), true);
  std::vector<Eigen::Vector3d> centroids(size_t(mesh.F.rows()));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    centroids[size_t(f)] = (mesh.V.row(mesh.F(f, 0)) + mesh.V.row(mesh.F(f, 1)) + mesh.V.row(mesh.F(f, 2))).transpose() / 3;
  }
  for (int alar : {31, 35}) {
    const Eigen::Vector3d mid = 0.5 * (landmarks.row(33) + landmarks.row(alar)).transpose();
    const double side = landmarks(alar, 0) - landmarks(33, 0);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    double weight = 0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
      const Eigen::Vector3d& c = centroids[size_t(f)];
      if (normals(f, 1) < -0.5 && (c - mid).norm() < 8 && (c.x() - landmarks(33, 0)) * side > 1.5) {
        centre += c;
        weight += 1;
      }
    }
    if (weight == 0) continue;
    centre /= weight;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
      if ((centroids[size_t(f)] - centre).norm() < 2.2 && normals(f, 1) < -0.2) keep[size_t(f)] = false;
    }
  }
  return keep;
}

// The scan's own atlas: two charts cut along the facial midline of the template parametrisation, each normalised,
// warped by a monotone (so still injective) per-axis sine, turned a quarter (either way) and stacked, in an order and
// with warps drawn from `seed`. Seams therefore cross the nose and lips, and no affine map relates it to the template UV.
void make_atlas(Mesh& mesh, const Eigen::MatrixX2d& template_uv, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const Eigen::Index nf = mesh.F.rows();
  std::vector<int> chart(static_cast<size_t>(nf));
  double split = 0;
  for (Eigen::Index v = 0; v < template_uv.rows(); ++v) split += template_uv(v, 0);
  split /= double(std::max<Eigen::Index>(1, template_uv.rows()));
  Eigen::Array2d lo[2], hi[2];
  for (int c = 0; c < 2; ++c) {
    lo[c].setConstant(1e30);
    hi[c].setConstant(-1e30);
  }
  for (Eigen::Index f = 0; f < nf; ++f) {
    double u = 0;
    for (int k = 0; k < 3; ++k) u += template_uv(mesh.F(f, k), 0) / 3;
    const int c = u < split ? 0 : 1;
    chart[size_t(f)] = c;
    for (int k = 0; k < 3; ++k) {
      lo[c] = lo[c].min(template_uv.row(mesh.F(f, k)).transpose().array());
      hi[c] = hi[c].max(template_uv.row(mesh.F(f, k)).transpose().array());
    }
  }
  // Turned a quarter, chart c is (hi-lo).y wide and (hi-lo).x tall; one scale for both keeps texel density even.
  const double gap = 0.01;
  const Eigen::Array2d size0 = hi[0] - lo[0], size1 = hi[1] - lo[1];
  const double scale = std::min((1 - 2 * gap) / std::max(size0.y(), size1.y()), (1 - 3 * gap) / (size0.x() + size1.x()));
  const bool swap = uniform(rng) < 0;
  double warp[2][2], turn[2], top[2];
  for (int c = 0; c < 2; ++c) {
    warp[c][0] = 0.35 * uniform(rng);
    warp[c][1] = 0.35 * uniform(rng);
    turn[c] = uniform(rng) < 0 ? -1 : 1;
  }
  const int upper = swap ? 1 : 0;
  top[upper] = 1 - gap;
  top[1 - upper] = 1 - 2 * gap - scale * (hi[upper] - lo[upper]).x();
  // UV index per (vertex, chart): vertices on the cut get one per chart, a seam.
  std::vector<int> index(size_t(mesh.V.rows()) * 2, -1);
  std::vector<Eigen::Vector2d> uvs;
  mesh.FUV.resize(nf, 3);
  for (Eigen::Index f = 0; f < nf; ++f) {
    const int c = chart[size_t(f)];
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.F(f, k);
      int& id = index[size_t(v) * 2 + size_t(c)];
      if (id < 0) {
        const Eigen::Array2d size = hi[c] - lo[c];
        Eigen::Array2d a = (template_uv.row(v).transpose().array() - lo[c]) / size;
        for (int d = 0; d < 2; ++d) a[d] += warp[c][d] * std::sin(M_PI * a[d]) / M_PI;  // derivative 1 + w cos > 0
        // Quarter turn: +1 maps (a, b) -> (b, 1 - a), -1 maps (a, b) -> (1 - b, a); then size in the atlas.
        const Eigen::Array2d turned = turn[c] > 0 ? Eigen::Array2d(a.y(), 1 - a.x()) : Eigen::Array2d(1 - a.y(), a.x());
        const Eigen::Vector2d uv(gap + scale * size.y() * turned.x(), top[c] - scale * size.x() * (1 - turned.y()));
        id = int(uvs.size());
        uvs.push_back(uv);
      }
      mesh.FUV(f, k) = id;
    }
  }
  mesh.UV.resize(Eigen::Index(uvs.size()), 2);
  for (size_t i = 0; i < uvs.size(); ++i) mesh.UV.row(Eigen::Index(i)) = uvs[i].transpose();
}

}  // namespace

SkinSurface template_skin_surface(const TemplateFace& face, const Eigen::MatrixX3d& displacement) {
  SkinSurface surface;
  surface.mesh = face.mesh;
  surface.mesh.V = face.mesh.V + displacement;
  surface.mesh.N = vertex_normals(surface.mesh.V, surface.mesh.F);
  surface.template_point = face.mesh.V;
  if (!per_vertex_uv(face.mesh, surface.template_uv)) {
    throw InvalidInput("template", "truth maps need one UV per template vertex (no seams)", "use a seamless template UV");
  }
  return surface;
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
  parallel_for(0, n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const SurfacePoint p = locator.locate(deformed.row(i).transpose());
      scan.truth_face(i) = p.face;
      scan.truth_barycentric.row(i) = p.barycentric.transpose();
      scan.truth_point.row(i) = p.point.transpose();
    }
  }, 1024);
  if (options.holes) {
    Eigen::MatrixX3d landmarks(68, 3);
    for (int k = 0; k < 68; ++k) landmarks.row(k) = deformed.row(face.landmark_vertices[size_t(k)]);
    const std::vector<int> face_map = remove_faces(scan.mesh, nostril_faces_kept(scan.mesh, landmarks));
    for (Eigen::Index i = 0; i < n; ++i) scan.truth_face(i) = face_map[size_t(scan.truth_face(i))];
    scan.mesh.N = vertex_normals(scan.mesh.V, scan.mesh.F);
  }
  // Where each scan vertex lies on the template: locate it on the deformed template (it was remeshed from it).
  const SurfaceLocator on_template(deformed, face.mesh.F);
  scan.surface.template_point.resize(scan.mesh.V.rows(), 3);
  scan.surface.template_uv.resize(scan.mesh.V.rows(), 2);
  parallel_for(0, scan.mesh.V.rows(), [&](int64_t b, int64_t e) {
    for (int64_t v = b; v < e; ++v) {
      const SurfacePoint p = on_template.locate(scan.mesh.V.row(v).transpose());
      Eigen::Vector3d point = Eigen::Vector3d::Zero();
      Eigen::Vector2d uv = Eigen::Vector2d::Zero();
      for (int k = 0; k < 3; ++k) {
        point += p.barycentric[k] * face.mesh.V.row(face.mesh.F(p.face, k)).transpose();
        uv += p.barycentric[k] * face.mesh.UV.row(face.mesh.FUV(p.face, k)).transpose();
      }
      scan.surface.template_point.row(v) = point.transpose();
      scan.surface.template_uv.row(v) = uv.transpose();
    }
  }, 1024);
  make_atlas(scan.mesh, scan.surface.template_uv, subject_seed(options.seed ^ 0xa71a5ull, index));
  scan.appearance = sample_appearance(subject_seed(options.seed ^ 0x5c1full, index));
  scan.appearance.detail = options.skin_detail;
  scan.surface.mesh = scan.mesh;

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
    // In a hole it follows the similarity only.
    for (Eigen::Index i = 0; i < n; ++i) {
      const int f = scan.truth_face(i);
      if (f < 0) {
        scan.truth_point.row(i) = (scan.scale * scan.rotation * scan.truth_point.row(i).transpose() + scan.translation).transpose();
        continue;
      }
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

void write_scan(const std::string& dir, const TemplateFace& face, const SyntheticScan& scan, const SynthOptions& options,
                const ProgressCallback& progress) {
  AtomicDirectory out(dir + "/" + scan.id);
  write_mesh(out.path() + "/mesh.obj", scan.mesh);
  const SkinModel skin(face, scan.appearance);
  if (options.maps.resolution > 0) SkinBaker(scan.surface, skin).bake(out.path(), options.maps, progress);
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
  params["tangential"] = options.identity.tangential;
  params["scan_vertices"] = scan.mesh.V.rows();
  params["scan_triangles"] = scan.mesh.F.rows();
  params["noise_mm"] = options.noise_mm;
  params["similarity"] = {{"scale", scan.scale},
                          {"rotation", {{scan.rotation(0, 0), scan.rotation(0, 1), scan.rotation(0, 2)},
                                        {scan.rotation(1, 0), scan.rotation(1, 1), scan.rotation(1, 2)},
                                        {scan.rotation(2, 0), scan.rotation(2, 1), scan.rotation(2, 2)}}},
                          {"translation", {scan.translation.x(), scan.translation.y(), scan.translation.z()}},
                          {"meaning", "x_scan = scale * rotation * x_identity + translation"}};
  params["appearance"] = scan.appearance.to_map();
  params["holes"] = options.holes;
  params["maps"] = {{"resolution", options.maps.resolution},
                    {"format", map_extension(options.maps.format)},
                    {"gutter_texels", options.maps.gutter},
                    {"truth_resolution", options.truth_resolution}};
  write_file_atomic(out.path() + "/truth/identity.json", params.dump(1) + "\n");
  if (options.truth_resolution > 0) {
    make_directories(out.path() + "/truth/maps");
    BakeOptions truth = options.maps;
    truth.resolution = options.truth_resolution;
    const SkinSurface surface = template_skin_surface(face, scan.identity.displacement);
    SkinBaker(surface, skin).bake(out.path() + "/truth/maps", truth);
  }
  out.commit();
}

void PopulationOptions::check() const {
  if (output.empty()) throw InvalidInput("-o", "names no population folder", "e.g. -o scans");
  synth.check();
}

void write_population(const PopulationOptions& options, const ProgressCallback& progress) {
  options.check();
  const std::string template_dir = find_template_folder(options.template_dir);
  const TemplateFace face = read_template_folder(template_dir);
  const SynthOptions& synth = options.synth;
  make_directories(options.output);
  // Resumable: a subject folder appears only when complete (atomic), so existing ones are skipped.
  std::vector<int> todo;
  for (int i = 0; i < synth.count; ++i) {
    char id[32];
    std::snprintf(id, sizeof id, "subject_%04d", i);
    if (!std::filesystem::exists(options.output + "/" + id + "/truth/identity.json")) todo.push_back(i);
  }
  if (todo.size() < size_t(synth.count)) {
    spdlog::info("scan synth: {} of {} subjects already there, skipped", synth.count - int(todo.size()), synth.count);
  }
  std::atomic<int> done{0};
  // Several subjects: one per thread. A single subject: its maps are baked in parallel, and the progress follows them.
  const bool one = todo.size() == 1;
  const ProgressCallback maps_progress = [&](int64_t d, int64_t total, const std::string&) {
    if (one && progress) progress(d, total, "map bands");
  };
  const auto make = [&](int64_t k) {
    write_scan(options.output, face, synthesize_scan(face, todo[size_t(k)], synth), synth, maps_progress);
    if (!one && progress) progress(++done, int64_t(todo.size()), "subjects");
  };
  if (one) {
    make(0);  // on this thread, so that the bake's own parallel_for is not nested (nested loops run serially)
  } else {
    parallel_for(0, int64_t(todo.size()), [&](int64_t b, int64_t e) {
      for (int64_t k = b; k < e; ++k) make(k);
    });
  }
  const std::vector<Blendshape> shapes = make_blendshapes(face);
  write_blendshapes(options.output + "/blendshapes", shapes);
  nlohmann::json manifest;
  manifest["format"] = "bareskin.scan_population";
  manifest["format_version"] = 1;
  manifest["seed"] = synth.seed;
  manifest["count"] = synth.count;
  manifest["template"] = std::filesystem::absolute(template_dir).string();
  manifest["identity_features"] = identity_feature_names();
  manifest["blendshapes"] = int(shapes.size());
  manifest["contents"] = "per subject mesh.obj (own topology and UV atlas), diffuse/normal/roughness/specular maps, "
                         "landmarks.json, truth/; blendshapes/ on the template";
  manifest["maps"] = {{"resolution", synth.maps.resolution}, {"format", options.map_format}};
  write_file_atomic(options.output + "/manifest.json", manifest.dump(1) + "\n");
}

}  // namespace bareskin
