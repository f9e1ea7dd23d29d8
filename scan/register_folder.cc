#include "scan/register_folder.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/mesh_io.h"
#include "core/parallel.h"
#include "core/safetensors.h"
#include "core/scan_folder.h"
#include "core/stats.h"
#include "render/preview.h"
#include "scan/transfer.h"

namespace bareskin {
namespace {

// Below this share of template vertices with an accepted closest point at the end, a registration has nothing to
// stand on (a fragment, a wrong unit, no face) and is refused rather than written.
constexpr double kMinAcceptedFraction = 0.3;

namespace fs = std::filesystem;

// Sanity of scans that parse but make no sense as a face (each refused with one line saying what to fix).
constexpr int kMinScanTriangles = 1000;  // a face scan has tens of thousands; fewer is a fragment or a proxy
constexpr double kMinHeadMm = 5;         // bounding-box diagonal: a head in millimetres spans 150-400

std::string scale_hint(double scale, const char* fix) {
  return scale == 1 ? std::string("rerun with ") + fix : "check --scale (now " + std::to_string(scale) + ")";
}

// The scan's mesh, scaled by `scale` (--scale), refused when it is too coarse or far too small to be millimetres.
Mesh read_scan_mesh(const std::string& path, double scale) {
  Mesh scan = read_mesh(path);
  scan.V *= scale;
  if (scan.F.rows() < kMinScanTriangles)
    throw InvalidInput(path, "has only " + std::to_string(scan.F.rows()) + " triangles (a face scan has " +
                                 std::to_string(kMinScanTriangles) + " or more): a fragment, a preview or a proxy mesh",
                       "give the full-resolution scan");
  const double diagonal = (scan.V.colwise().maxCoeff() - scan.V.colwise().minCoeff()).norm();
  if (diagonal < kMinHeadMm) {
    char what[160];
    std::snprintf(what, sizeof what, "spans %.3g units corner to corner (a head in millimetres: 150-400): the scan "
                  "looks like metres", diagonal);
    throw InvalidInput(path, what, scale_hint(scale, "--scale 1000"));
  }
  return scan;
}

// Landmarks of a file must lie on the scan: within its bounding box grown by a tenth of its diagonal.
void check_landmarks_on_scan(const Mesh& scan, const Landmarks& landmarks, const std::string& path) {
  const Eigen::RowVector3d lo = scan.V.colwise().minCoeff(), hi = scan.V.colwise().maxCoeff();
  const double margin = 0.1 * (hi - lo).norm();
  for (Eigen::Index k = 0; k < landmarks.points.rows(); ++k) {
    const Eigen::RowVector3d p = landmarks.points.row(k);
    const Eigen::RowVector3d inside =
        p.cwiseMax((lo.array() - margin).matrix()).cwiseMin((hi.array() + margin).matrix());
    if ((p - inside).norm() > 0) {
      char what[200];
      std::snprintf(what, sizeof what, "landmark %d lies %.3g mm outside the scan's bounding box (grown by %.3g mm)",
                    int(k), (p - inside).norm(), margin);
      throw InvalidInput(path, what, "the landmarks belong to another scan, frame or unit: fix landmarks.json or "
                                     "remove it (then the fallback or --detect-landmarks places them)");
    }
  }
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

// Where a scan's landmarks come from: its landmarks.json, the detector, or none (the fallback alignment). Detected
// points are a few mm off (docs/cli.md): they place the template, then give way to the surface early.
struct ScanLandmarkSource {
  std::optional<Landmarks> landmarks;
  nlohmann::json detected;  // null unless detected
  RegisterOptions nicp;
};

ScanLandmarkSource scan_landmarks(const TemplateFace& face, const Mesh& scan, const std::string& scan_dir,
                                  const RegisterFolderOptions& options) {
  ScanLandmarkSource out;
  out.nicp = options.nicp;
  if (options.no_landmarks) return out;
  if (fs::exists(scan_dir + "/landmarks.json")) {
    const std::string path = scan_dir + "/landmarks.json", text = read_file(path);
    out.landmarks = parse_landmarks_json(text, path);
    out.landmarks->points *= options.scale;
    check_scan_landmarks(face, *out.landmarks, path);
    check_landmarks_on_scan(scan, *out.landmarks, path);
    out.nicp.landmark_sigma_mm = parse_landmark_sigma(text);
    return out;
  }
  if (!options.detect) return out;
  std::optional<Image> diffuse;
  if (const std::string p = find_scan_map(scan_dir, "diffuse"); !p.empty() && scan.has_uv()) diffuse = to_linear(read_image(p));
  const DetectedLandmarks found = options.detect(scan, diffuse ? &*diffuse : nullptr);
  out.landmarks = found.landmarks;
  // Calibrated points follow the template's convention, jaw included; otherwise the jaw contour (where a 2D
  // detector sees the outline) and points that were not triangulated are left out; --landmark-ids narrows them.
  const std::vector<int> asked = out.nicp.landmark_ids;
  out.nicp.landmark_ids.clear();
  for (int k = found.calibrated ? 0 : 17; k < 68; ++k)
    if (found.landmarks.points.row(k).allFinite() && (asked.empty() || std::count(asked.begin(), asked.end(), k)))
      out.nicp.landmark_ids.push_back(k);
  for (int k = 0; k < 68; ++k)
    if (!found.landmarks.points.row(k).allFinite()) out.landmarks->points.row(k).setZero();  // unused, kept finite
  for (size_t i = 0; i < out.nicp.landmark_weight.size(); ++i)
    out.nicp.landmark_weight[i] = i < 3 ? 10.0 / std::pow(3.0, double(i)) : 0;
  if (found.sigma_mm.size() == 68) out.nicp.landmark_sigma_mm = found.sigma_mm;
  out.detected = {{"detector_score", found.detector_score},
                  {"used", found.calibrated ? "calibrated, " + std::to_string(out.nicp.landmark_ids.size()) + " points"
                                            : std::to_string(out.nicp.landmark_ids.size()) +
                                                  " points of 17-67 (the jaw contour is left out)"},
                  {"views", found.views},
                  {"snapped_to_silhouette", found.snapped_to_silhouette}};
  return out;
}

// The dense truth correspondence, when the scan came from `scan synth`.
struct Truth {
  std::optional<Eigen::MatrixX3d> point;
  std::optional<Eigen::VectorXi> face;
};

Truth read_truth(const std::string& scan_dir, int64_t template_vertices) {
  Truth t;
  const std::string path = scan_dir + "/truth/correspondence.safetensors";
  if (!fs::exists(path)) return t;
  const SafeTensors truth = SafeTensors::open(path);
  const int64_t n = template_vertices;
  const std::vector<float> p = truth.tensor("template_to_scan_point", DType::F32, {n, 3}).to_vector<float>();
  const std::vector<int32_t> f = truth.tensor("template_to_scan_face", DType::I32, {n}).to_vector<int32_t>();
  t.point = Eigen::Map<const Eigen::Matrix<float, -1, 3, Eigen::RowMajor>>(p.data(), n, 3).cast<double>();
  t.face = Eigen::Map<const Eigen::VectorXi>(f.data(), n);
  return t;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// The detected points against the template's landmark vertices carried onto the scan by the truth.
nlohmann::json detected_vs_truth(const TemplateFace& face, const Landmarks& landmarks, const Eigen::MatrixX3d& truth) {
  std::vector<double> e;
  for (int k = 0; k < 68; ++k) e.push_back((landmarks.points.row(k) - truth.row(face.landmark_vertices[size_t(k)])).norm());
  return {{"median", median(e)}, {"median_17_67", median(std::vector<double>(e.begin() + 17, e.end()))}};
}

// Whichever maps the scan has, into the template UV at options.maps.resolution; the report's "maps" entry.
nlohmann::json transfer_scan_maps(const Mesh& registered, const Mesh& scan, const std::string& scan_dir,
                                  const std::string& out_dir, const BakeOptions& maps_options) {
  const auto t0 = std::chrono::steady_clock::now();
  const ScanMaps maps = read_scan_maps(scan_dir);
  nlohmann::json j = {{"transferred", maps.names()}};
  if (!maps.present().any()) {
    j["note"] = "the scan has no diffuse, normal, roughness or specular map: geometry only";
    return j;
  }
  const TransferResult tr = transfer_maps(registered, scan, maps, maps_options, out_dir);
  j["resolution"] = maps_options.resolution;
  j["seconds"] = seconds_since(t0);
  const std::string truth_maps = scan_dir + "/truth/maps";
  const std::string truth_diffuse = truth_maps + "/diffuse" + map_extension(maps_options.format);
  if (fs::exists(truth_diffuse) && probe_image(truth_diffuse).width == maps_options.resolution) {
    const TransferErrors te = compare_maps(out_dir, truth_maps, tr.texel_class);
    nlohmann::json vs = {{"texels_away_from_seams", te.texels}};
    if (te.has_diffuse) vs["diffuse_psnr_db"] = te.diffuse_psnr_db;
    if (te.has_normal) vs["normal_angle_median_deg"] = te.normal_median_deg, vs["normal_angle_p95_deg"] = te.normal_p95_deg;
    j["vs_truth"] = vs;
  }
  return j;
}

// QA: the error per vertex as a heat map (blue 0 .. red heat_max_mm), front and left.
void write_qa(const Mesh& registered, const Eigen::VectorXd& per_vertex, double heat_max_mm, const std::string& dir) {
  PreviewOptions preview;
  preview.size = 512;
  preview.wireframe = false;
  preview.vertex_colors.resize(registered.V.rows(), 3);
  for (Eigen::Index i = 0; i < registered.V.rows(); ++i) {
    preview.vertex_colors.row(i) = heat_color(per_vertex(i) / heat_max_mm).transpose();
  }
  write_image(dir + "/qa_front.png", render_preview(registered, preview));
  preview.view = PreviewView::Left;
  write_image(dir + "/qa_left.png", render_preview(registered, preview));
}

nlohmann::json registration_report(const std::string& id, const std::string& mesh_path, const Mesh& scan,
                                   const Registration& reg, const RegistrationErrors& err, const nlohmann::json& detected) {
  const RegistrationStats& s = reg.stats;
  nlohmann::json report;
  report["subject"] = id;
  report["scan"] = mesh_path;
  report["scan_vertices"] = scan.V.rows();
  report["scan_triangles"] = scan.F.rows();
  report["alignment"] = !s.used_landmarks ? "FALLBACK: no landmarks; centroid + RMS radius + similarity ICP"
                        : detected.is_null() ? "landmarks (Umeyama similarity)"
                                             : "detected landmarks 17-67 (Umeyama similarity)";
  if (!detected.is_null()) report["landmarks_detected"] = detected;
  report["similarity_scale"] = s.similarity_scale;
  report["landmark_rms_after_similarity_mm"] = s.landmark_rms_after_similarity_mm;
  report["nicp_iterations"] = s.iterations;
  report["nicp_nodes"] = s.nodes;
  report["accepted_fraction"] = s.accepted_fraction;
  report["surface_distance_mm"] = {{"median", err.distance_median}, {"p95", err.distance_p95}, {"max", err.distance_max}};
  if (err.has_truth) {
    report["correspondence_error_mm"] = {
        {"median", err.correspondence_median}, {"p95", err.correspondence_p95}, {"max", err.correspondence_max}};
  }
  if (err.has_landmarks) report["landmark_error_mm"] = {{"mean", err.landmark_mean}, {"max", err.landmark_max}};
  return report;
}

// The texture refinement's report entry: rounds, targets, moves, time, and the error before it (against the truth).
nlohmann::json texture_report(const TemplateFace& face, const Registration& reg, const Mesh& scan, const Truth& truth) {
  const RegistrationStats& s = reg.stats;
  nlohmann::json j = {{"rounds", s.texture_targets.size()},
                      {"targets", s.texture_targets},
                      {"median_move_mm", s.texture_median_flow_mm},
                      {"seconds", s.seconds_texture}};
  if (truth.point) {
    const RegistrationErrors before = measure_registration(face, reg.V_before_texture, scan, nullptr, &*truth.point,
                                                           truth.face ? &*truth.face : nullptr);
    j["correspondence_error_before_mm"] = {{"median", before.correspondence_median},
                                           {"p95", before.correspondence_p95},
                                           {"max", before.correspondence_max}};
  }
  return j;
}

// The model prior's report entry: rounds' point-to-plane RMS, |α|, landmark RMS after the fit, time, and the fitted
// shape's own correspondence error (against the truth, before NICP).
nlohmann::json model_report(const TemplateFace& face, const Registration& reg, const Mesh& scan, const Truth& truth,
                            const std::string& model_path) {
  const RegistrationStats& s = reg.stats;
  nlohmann::json j = {{"model", model_path},
                      {"point_to_plane_rms_mm", s.model_rms_mm},
                      {"alpha_norm", s.model_alpha_norm},
                      {"landmark_rms_after_fit_mm", s.model_landmark_rms_mm},
                      {"vertices_used", s.model_vertices_used},
                      {"seconds", s.seconds_model}};
  if (truth.point) {
    const RegistrationErrors fit = measure_registration(face, reg.V_model, scan, nullptr, &*truth.point,
                                                        truth.face ? &*truth.face : nullptr);
    j["correspondence_error_after_fit_mm"] = {{"median", fit.correspondence_median}, {"p95", fit.correspondence_p95}};
  }
  return j;
}

bool uses_texture(const TextureRefineOptions& o) { return o.iterations > 0 || o.landmark_rounds > 0; }

nlohmann::json register_one(const TemplateFace& face, const std::string& scan_dir, const RegisterFolderOptions& options,
                            const Image* texture_reference, const MorphableModel* model) {
  // 1. Read the scan and its landmarks (given, detected or none).
  const auto t0 = std::chrono::steady_clock::now();
  const std::string id = fs::path(scan_dir).filename().string(), mesh_path = find_scan_mesh(scan_dir);
  if (mesh_path.empty())
    throw InvalidInput(scan_dir, "holds no mesh.obj or mesh.ply", "point --scans at a folder of scan folders");
  const Mesh scan = read_scan_mesh(mesh_path, options.scale);
  const ScanLandmarkSource lm = scan_landmarks(face, scan, scan_dir, options);
  const Landmarks* landmarks = lm.landmarks ? &*lm.landmarks : nullptr;
  const double read_seconds = seconds_since(t0);

  // 2. Register, and measure against the surface, the landmarks and (for synthetic scans) the truth.
  std::optional<Image> scan_diffuse;
  RegistrationTexture texture;
  if (uses_texture(options.nicp.texture) && texture_reference) {
    if (const std::string p = find_scan_map(scan_dir, "diffuse"); !p.empty() && scan.has_uv()) {
      scan_diffuse = to_linear(read_image(p));
      texture = {&*scan_diffuse, texture_reference};
    }
  }
  const Registration reg = register_scan(face, scan, landmarks, lm.nicp, {}, texture, model);
  if (reg.stats.accepted_fraction < kMinAcceptedFraction) {  // a fragment, or no face: nothing is registered to
    char what[160];
    std::snprintf(what, sizeof what, "the template found this surface under only %.0f%% of its vertices (a face scan: 80%%+)",
                  100 * reg.stats.accepted_fraction);
    throw InvalidInput(mesh_path, what, "give a whole face scan in millimetres, not a fragment");
  }
  const Truth truth = read_truth(scan_dir, face.mesh.V.rows());
  const RegistrationErrors err = measure_registration(face, reg.V, scan, landmarks, truth.point ? &*truth.point : nullptr,
                                                      truth.face ? &*truth.face : nullptr);

  // 3. Outputs: the registered mesh, the maps the scan has, QA pictures, the report; all or nothing.
  AtomicDirectory out(options.output + "/" + id);
  nlohmann::json detected = lm.detected;
  if (!detected.is_null()) {
    write_landmarks(out.path() + "/landmarks_detected.json", *landmarks);
    if (truth.point) detected["error_vs_truth_mm"] = detected_vs_truth(face, *landmarks, *truth.point);
  }
  Mesh registered = face.mesh;
  registered.V = reg.V;
  registered.N = vertex_normals(registered.V, registered.F);
  write_mesh(out.path() + "/mesh.ply", registered);  // binary PLY: template topology, per-vertex UVs
  nlohmann::json maps;
  if (options.maps.resolution > 0) maps = transfer_scan_maps(registered, scan, scan_dir, out.path(), options.maps);
  write_qa(registered, err.per_vertex, options.heat_max_mm, out.path());

  nlohmann::json report = registration_report(id, mesh_path, scan, reg, err, detected);
  const RegistrationStats& s = reg.stats;
  report["seconds"] = {{"read", read_seconds},
                       {"similarity", s.seconds_similarity},
                       {"model_fit", s.seconds_model},
                       {"nicp", s.seconds_nicp},
                       {"nicp_correspondences", s.seconds_correspond},
                       {"nicp_factorize_solve", s.seconds_factorize},
                       {"nicp_nodes", s.seconds_nodes},
                       {"nicp_projection", s.seconds_project},
                       {"total", seconds_since(t0)}};
  if (!maps.is_null()) report["maps"] = maps;
  if (s.used_model) report["model_prior"] = model_report(face, reg, scan, truth, options.model);
  if (reg.V_before_texture.rows() > 0) report["texture_refine"] = texture_report(face, reg, scan, truth);
  else if (options.nicp.texture.iterations > 0) report["texture_refine"] = {{"note", "the scan has no diffuse map or no UVs: not refined"}};
  report["seconds"]["texture_refine"] = s.seconds_texture;
  if (!s.texture_landmarks_found.empty()) {
    report["texture_landmarks"] = {{"rounds", s.texture_landmarks_found.size()},
                                   {"found", s.texture_landmarks_found},
                                   {"median_move_mm", s.texture_landmarks_move_mm}};
    const TextureLandmarks& t = reg.texture_landmarks;  // the last round used
    nlohmann::json points = nlohmann::json::array();  // iBUG index, then x y z in the scan's frame
    for (const int k : t.ids) points.push_back({k, t.landmarks.points(k, 0), t.landmarks.points(k, 1), t.landmarks.points(k, 2)});
    if (!points.empty()) report["texture_landmarks"]["points"] = points;
    report["texture_landmarks"]["shape_points"] = {{"found", s.shape_points_found}};
    // With truth: the found landmarks and shape points against the truth's points at their template vertices.
    const auto error_mm = [&](const std::vector<double>& e) {
      return nlohmann::json{{"median", quantile(e, 0.5)}, {"p90", quantile(e, 0.9)}};
    };
    std::vector<double> landmark_error, shape_error;
    if (truth.point) {
      for (const int k : t.ids)
        landmark_error.push_back((t.landmarks.points.row(k) - truth.point->row(face.landmark_vertices[size_t(k)])).norm());
      for (size_t j = 0; j < t.shape_vertex.size(); ++j)
        shape_error.push_back((t.shape_point[j].transpose() - truth.point->row(t.shape_vertex[j])).norm());
    }
    if (!landmark_error.empty()) report["texture_landmarks"]["error_mm"] = error_mm(landmark_error);
    if (!shape_error.empty()) report["texture_landmarks"]["shape_points"]["error_mm"] = error_mm(shape_error);
  } else if (options.nicp.texture.landmark_rounds > 0) {
    report["texture_landmarks"] = {{"note", "the scan has no diffuse map or no UVs: none found"}};
  }
  report["seconds"]["texture_landmarks"] = s.seconds_texture_landmarks;
  if (s.outline_median_mm >= 0) {
    report["outline"] = {{"weight", options.nicp.outline_weight},
                         {"distance_to_scan_border_mm", {{"median", s.outline_median_mm}, {"max", s.outline_max_mm}}}};
  }
  report["qa"] = {{"heat_map", "per-vertex " + std::string(err.has_truth ? "correspondence error" : "surface distance") +
                                   ", blue 0 to red " + std::to_string(options.heat_max_mm) + " mm"}};
  write_file_atomic(out.path() + "/report.json", report.dump(1) + "\n");
  out.commit();
  return report;
}

std::vector<std::string> scan_folders(const std::string& scans) {
  if (!fs::is_directory(scans)) {
    throw IoError(scans, "is not a folder", "give the folder 'scan synth' wrote, or one of scan folders");
  }
  std::vector<std::string> dirs;
  for (const auto& entry : fs::directory_iterator(scans)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory() || name.empty() || name[0] == '.' || name == "blendshapes") continue;
    dirs.push_back(entry.path().string());
  }
  std::sort(dirs.begin(), dirs.end());
  if (dirs.empty()) throw InvalidInput(scans, "holds no scan folders", "run 'bareskin scan synth' first");
  return dirs;
}

void log_report(const nlohmann::json& r) {
  std::string line = fmt::format("{}: surface distance median {:.3f} mm", r["subject"].get<std::string>(),
                                 r["surface_distance_mm"]["median"].get<double>());
  if (r.contains("correspondence_error_mm")) {
    line += fmt::format(", correspondence error median {:.3f} / p95 {:.3f} mm",
                        r["correspondence_error_mm"]["median"].get<double>(), r["correspondence_error_mm"]["p95"].get<double>());
  }
  if (r.contains("landmark_error_mm")) line += fmt::format(", landmarks {:.2f} mm", r["landmark_error_mm"]["mean"].get<double>());
  if (r.contains("maps") && r["maps"].contains("vs_truth")) {
    const auto& vs = r["maps"]["vs_truth"];
    if (vs.contains("diffuse_psnr_db")) line += fmt::format(", diffuse PSNR {:.1f} dB", vs["diffuse_psnr_db"].get<double>());
    if (vs.contains("normal_angle_median_deg"))
      line += fmt::format(", normals {:.2f} deg", vs["normal_angle_median_deg"].get<double>());
  }
  if (r.contains("maps")) {
    const auto& t = r["maps"]["transferred"];
    if (t.empty()) line += ", no maps (geometry only)";
    else if (t.size() < 4) line += ", maps: " + t.dump();
  }
  spdlog::info("{}, {:.1f} s", line, r["seconds"]["total"].get<double>());
}

}  // namespace

std::vector<double> parse_landmark_sigma(const std::string& text) {
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("detail") || !doc["detail"].is_array() ||
      doc["detail"].size() != 68) {
    return {};
  }
  std::vector<double> sigma;
  for (const auto& d : doc["detail"])
    sigma.push_back(d.is_object() && d.contains("sigma_mm") && d["sigma_mm"].is_number() ? d["sigma_mm"].get<double>() : 0.0);
  return sigma;
}

void RegisterFolderOptions::check() const {
  if (scans.empty() || output.empty())
    throw InvalidInput("--scans/--output", "a folder is not named", "give the scans' folder and the output folder");
  if (!(scale > 0 && scale < 1e9))
    throw InvalidInput("--scale", "must be a positive factor", "1 for scans in mm, 1000 for scans in metres");
  if (!(heat_max_mm > 0)) throw InvalidInput("--heat-max", "must be > 0 mm", "e.g. --heat-max 2");
  nicp.check();
  if (maps.resolution != 0) maps.check();
}

std::vector<std::string> register_folder(const TemplateFace& face, const RegisterFolderOptions& options,
                                         const ProgressCallback& progress) {
  options.check();
  // 1. The scan folders, and which of them still need registering.
  const std::vector<std::string> dirs = scan_folders(options.scans);
  const auto out_dir = [&](const std::string& d) { return options.output + "/" + fs::path(d).filename().string(); };
  std::vector<std::string> todo;
  for (const std::string& d : dirs)
    if (!fs::exists(out_dir(d) + "/report.json")) todo.push_back(d);
  if (todo.size() < dirs.size()) {
    spdlog::info("scan register: {} of {} scans already registered, skipped", dirs.size() - todo.size(), dirs.size());
  }

  // 2. Register them, in parallel over scans (one scan: the registration's own loops get every thread).
  std::optional<Image> reference;
  if (uses_texture(options.nicp.texture) && !todo.empty()) {
    if (options.texture_reference.empty()) {
      throw InvalidInput(options.nicp.texture.iterations > 0 ? "--texture-refine" : "--texture-landmarks",
                         "needs a reference diffuse in the template UV",
                         "give --texture-reference UV.png (docs/pipeline.md says how to make one)");
    }
    reference = read_image(options.texture_reference);
    if (reference->width != reference->height || reference->channels < 3 || reference->color_space == ColorSpace::Data) {
      throw InvalidInput(options.texture_reference, "is not a square RGB colour image",
                         "give the template-UV diffuse (e.g. the mean of registered diffuse.png maps)");
    }
  }
  std::optional<MorphableModel> model;
  if (!options.model.empty() && !todo.empty()) {
    model = read_model(options.model);
    check_model_template(*model, face.mesh, face.landmark_vertices, options.model);
    if (model->shape_basis.rows() == 0) {
      throw InvalidInput(options.model, "has no identity components", "build it from at least two registered subjects");
    }
  }
  // After the inputs are checked, and removed again if it is still empty when a scan fails: bad input (here or in
  // the first scan) leaves no output folder.
  const bool made_output = !fs::exists(options.output);
  make_directories(options.output);
  struct RemoveIfEmpty {
    const std::string& dir;
    bool armed;
    ~RemoveIfEmpty() {
      std::error_code ec;
      if (armed && fs::is_empty(dir, ec) && !ec) fs::remove(dir, ec);
    }
  } cleanup{options.output, made_output};
  std::atomic<int> done{0};
  std::mutex failures_mutex;
  std::vector<std::pair<std::string, std::string>> failures;
  const auto one = [&](int64_t k) {
    try {
      register_one(face, todo[size_t(k)], options, reference ? &*reference : nullptr, model ? &*model : nullptr);
    } catch (const std::exception& e) {
      const std::string& dir = todo[size_t(k)];  // name the scan in messages that do not ("scan: ICP found no overlap")
      const bool named = std::string(e.what()).find(dir) != std::string::npos;
      if (!options.keep_going && !named && dynamic_cast<const InvalidInput*>(&e)) throw InvalidInput(dir + ": " + e.what());
      if (!options.keep_going && !named && dynamic_cast<const IoError*>(&e)) throw IoError(dir + ": " + e.what());
      if (!options.keep_going) throw;
      std::lock_guard<std::mutex> lock(failures_mutex);
      failures.emplace_back(todo[size_t(k)], e.what());
    }
    report(progress, ++done, int64_t(todo.size()), "scans");
  };
  if (todo.size() == 1) {
    one(0);
  } else {
    parallel_for(0, int64_t(todo.size()), [&](int64_t b, int64_t e) {
      for (int64_t k = b; k < e; ++k) one(k);
    });
  }

  // 3. The summary over every registered scan (including ones from earlier runs), and the failures.
  nlohmann::json summary, rows = nlohmann::json::array();
  for (const std::string& d : dirs) {
    const std::string report_path = out_dir(d) + "/report.json";
    if (fs::exists(report_path)) rows.push_back(nlohmann::json::parse(read_file(report_path)));
  }
  summary["format"] = "bareskin.registration_summary";
  summary["scans"] = rows;
  summary["failures"] = nlohmann::json::array();
  for (const auto& [dir, why] : failures) summary["failures"].push_back({{"scan", dir}, {"error", why}});
  write_file_atomic(options.output + "/summary.json", summary.dump(1) + "\n");
  cleanup.armed = false;
  for (const auto& r : rows) log_report(r);
  if (!failures.empty()) {
    for (const auto& [dir, why] : failures) spdlog::error("{}: {}", dir, why);
    throw InvalidInput(options.scans, std::to_string(failures.size()) + " scan(s) failed (listed above and in summary.json)",
                       "fix them and rerun: registered scans are skipped");
  }
  std::vector<std::string> registered;
  for (const std::string& d : dirs) registered.push_back(out_dir(d));
  return registered;
}

std::vector<std::string> register_folder(const std::string& template_dir, const RegisterFolderOptions& options,
                                         const ProgressCallback& progress) {
  options.check();
  return register_folder(read_template_folder(template_dir), options, progress);
}

}  // namespace bareskin
