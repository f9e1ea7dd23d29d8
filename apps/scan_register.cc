// bareskin scan register: the template onto every scan of a folder (landmark similarity + optimal-step NICP), with an
// error report per scan (and against the truth when the scan has one) and a QA heat map.
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>

#include "apps/scan_register.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "core/parallel.h"
#include "core/safetensors.h"
#include "core/landmarks.h"
#ifdef BARESKIN_WITH_DETECT
#include "detect/scan_landmarks.h"
#endif
#include "render/preview.h"
#include "scan/register.h"
#include "scan/transfer.h"

namespace bareskin::cli {
namespace {

namespace fs = std::filesystem;


// The scan's mesh file: mesh.obj, else mesh.ply.
std::string scan_mesh_path(const std::string& dir) {
  for (const char* name : {"/mesh.obj", "/mesh.ply"}) {
    if (fs::exists(dir + name)) return dir + name;
  }
  throw InvalidInput(dir, "holds no mesh.obj or mesh.ply", "point --scans at a folder of scan folders");
}

nlohmann::json register_one(const TemplateFace& face, const std::string& scan_dir, const std::string& out_root,
                            const RegisterArgs& args) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::string id = fs::path(scan_dir).filename().string();
  const Mesh scan = read_mesh(scan_mesh_path(scan_dir));
  std::optional<Landmarks> landmarks;
  nlohmann::json detected;
  RegisterOptions nicp = args.nicp;
  if (!args.no_landmarks && fs::exists(scan_dir + "/landmarks.json")) {
    landmarks = read_landmarks(scan_dir + "/landmarks.json");
    check_scan_landmarks(face, *landmarks, scan_dir + "/landmarks.json");
  }
#ifdef BARESKIN_WITH_DETECT
  else if (!args.no_landmarks) {  // none given: detect them in a front render of the textured scan
    std::optional<Image> diffuse;
    for (const char* name : {"/diffuse.png", "/diffuse.exr", "/diffuse.tif", "/diffuse.tiff"})
      if (!diffuse && fs::exists(scan_dir + name) && scan.has_uv()) diffuse = to_linear(read_image(scan_dir + name));
    static const detect::FaceApi net(detect::default_face_api_folder());
    const auto found = detect::detect_scan_landmarks(net, scan, diffuse ? &*diffuse : nullptr);
    landmarks = found.landmarks;
    // Detected points are a few mm off (docs/cli.md): they place the template, then give way to the surface early.
    for (int k = 17; k < 68; ++k) nicp.landmark_ids.push_back(k);
    for (size_t i = 0; i < nicp.landmark_weight.size(); ++i) nicp.landmark_weight[i] = i < 3 ? 10.0 / std::pow(3.0, i) : 0;
    detected = {{"detector_score", found.detector_score}, {"used", "17-67 (the jaw contour is left out)"},
                {"snapped_to_silhouette", found.off_surface}};
  }
#endif
  const double read_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const Registration reg = register_scan(face, scan, landmarks ? &*landmarks : nullptr, nicp);

  // Truth, when the scan came from `scan synth`.
  std::optional<Eigen::MatrixX3d> truth_point;
  std::optional<Eigen::VectorXi> truth_face;
  const std::string truth_path = scan_dir + "/truth/correspondence.safetensors";
  if (fs::exists(truth_path)) {
    const SafeTensors truth = SafeTensors::open(truth_path);
    const int64_t n = face.mesh.V.rows();
    const std::vector<float> p = truth.tensor("template_to_scan_point", DType::F32, {n, 3}).to_vector<float>();
    const std::vector<int32_t> f = truth.tensor("template_to_scan_face", DType::I32, {n}).to_vector<int32_t>();
    truth_point = Eigen::Map<const Eigen::Matrix<float, -1, 3, Eigen::RowMajor>>(p.data(), n, 3).cast<double>();
    truth_face = Eigen::Map<const Eigen::VectorXi>(f.data(), n);
  }
  const RegistrationErrors err = measure_registration(face, reg.V, scan, landmarks ? &*landmarks : nullptr,
                                                      truth_point ? &*truth_point : nullptr,
                                                      truth_face ? &*truth_face : nullptr);

  AtomicDirectory out(out_root + "/" + id);
  if (!detected.is_null()) {
    write_landmarks(out.path() + "/landmarks_detected.json", *landmarks);
    if (truth_point) {  // the detected points against the template's landmark vertices carried onto the scan
      std::vector<double> e;
      for (int k = 0; k < 68; ++k)
        e.push_back((landmarks->points.row(k) - truth_point->row(face.landmark_vertices[size_t(k)])).norm());
      std::vector<double> inner(e.begin() + 17, e.end());
      auto median = [](std::vector<double> v) {
        std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
        return v[v.size() / 2];
      };
      detected["error_vs_truth_mm"] = {{"median", median(e)}, {"median_17_67", median(inner)}};
    }
  }
  Mesh registered = face.mesh;
  registered.V = reg.V;
  registered.N = vertex_normals(registered.V, registered.F);
  write_mesh(out.path() + "/mesh.ply", registered);  // binary PLY: template topology, per-vertex UVs
  nlohmann::json transfer;
  if (args.maps.resolution > 0) {
    const auto t_maps = std::chrono::steady_clock::now();
    const TransferResult tr = transfer_maps(registered, scan, read_scan_maps(scan_dir), args.maps, out.path());
    transfer["resolution"] = args.maps.resolution;
    transfer["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_maps).count();
    const std::string truth_maps = scan_dir + "/truth/maps";
    if (fs::exists(truth_maps + "/diffuse" + map_extension(args.maps.format)) &&
        probe_image(truth_maps + "/diffuse" + map_extension(args.maps.format)).width == args.maps.resolution) {
      const TransferErrors te = compare_maps(out.path(), truth_maps, tr.texel_class);
      transfer["vs_truth"] = {{"diffuse_psnr_db", te.diffuse_psnr_db}, {"normal_angle_median_deg", te.normal_median_deg},
                              {"normal_angle_p95_deg", te.normal_p95_deg}, {"texels_away_from_seams", te.texels}};
    }
  }
  // QA: the error per vertex as a heat map (blue 0 .. red heat_max_mm), front and left.
  PreviewOptions preview;
  preview.size = 512;
  preview.wireframe = false;
  preview.vertex_colors.resize(registered.V.rows(), 3);
  for (Eigen::Index i = 0; i < registered.V.rows(); ++i) {
    preview.vertex_colors.row(i) = heat_color(err.per_vertex(i) / args.heat_max_mm).transpose();
  }
  write_image(out.path() + "/qa_front.png", render_preview(registered, preview));
  preview.view = PreviewView::Left;
  write_image(out.path() + "/qa_left.png", render_preview(registered, preview));

  const RegistrationStats& s = reg.stats;
  nlohmann::json report;
  report["subject"] = id;
  report["scan"] = scan_mesh_path(scan_dir);
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
  const double total = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  report["seconds"] = {{"read", read_seconds},
                       {"similarity", s.seconds_similarity},
                       {"nicp", s.seconds_nicp},
                       {"nicp_correspondences", s.seconds_correspond},
                       {"nicp_factorize_solve", s.seconds_factorize},
                       {"total", total}};
  if (!transfer.empty()) report["maps"] = transfer;
  report["qa"] = {{"heat_map", "per-vertex " + std::string(err.has_truth ? "correspondence error" : "surface distance") +
                                   ", blue 0 to red " + std::to_string(args.heat_max_mm) + " mm"}};
  write_file_atomic(out.path() + "/report.json", report.dump(1) + "\n");
  out.commit();
  return report;
}

}  // namespace

std::vector<std::string> register_folder(const TemplateFace& face, const RegisterArgs& args, const Globals& globals) {
  if (!fs::is_directory(args.scans)) {
    throw IoError(args.scans, "is not a folder", "give the folder 'scan synth' wrote, or one of scan folders");
  }
  std::vector<std::string> dirs;
  for (const auto& entry : fs::directory_iterator(args.scans)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory() || name.empty() || name[0] == '.' || name == "blendshapes") continue;
    dirs.push_back(entry.path().string());
  }
  std::sort(dirs.begin(), dirs.end());
  if (dirs.empty()) throw InvalidInput(args.scans, "holds no scan folders", "run 'bareskin scan synth' first");
  make_directories(args.output);
  std::vector<std::string> todo;
  for (const std::string& d : dirs) {
    if (!fs::exists(args.output + "/" + fs::path(d).filename().string() + "/report.json")) todo.push_back(d);
  }
  if (todo.size() < dirs.size()) spdlog::info("scan register: {} of {} scans already registered, skipped", dirs.size() - todo.size(), dirs.size());
  ProgressBar bar = globals.progress("scan register");
  std::atomic<int> done{0};
  std::mutex failures_mutex;
  std::vector<std::pair<std::string, std::string>> failures;
  const auto one = [&](int64_t k) {
    try {
      register_one(face, todo[size_t(k)], args.output, args);
    } catch (const std::exception& e) {
      if (!args.keep_going) throw;
      std::lock_guard<std::mutex> lock(failures_mutex);
      failures.emplace_back(todo[size_t(k)], e.what());
    }
    bar.update(++done, int64_t(todo.size()), "scans");
  };
  if (todo.size() == 1) {
    one(0);  // the registration's own parallel loops get every thread
  } else {
    parallel_for(0, int64_t(todo.size()), [&](int64_t b, int64_t e) {
      for (int64_t k = b; k < e; ++k) one(k);
    });
  }
  bar.finish();
  // Summary over every registered scan (including ones from earlier runs).
  nlohmann::json summary, rows = nlohmann::json::array();
  for (const std::string& d : dirs) {
    const std::string report = args.output + "/" + fs::path(d).filename().string() + "/report.json";
    if (fs::exists(report)) rows.push_back(nlohmann::json::parse(read_file(report)));
  }
  summary["format"] = "bareskin.registration_summary";
  summary["scans"] = rows;
  summary["failures"] = nlohmann::json::array();
  for (const auto& [dir, why] : failures) summary["failures"].push_back({{"scan", dir}, {"error", why}});
  write_file_atomic(args.output + "/summary.json", summary.dump(1) + "\n");
  globals.write_resolved_config(args.output + "/config.json");
  for (const auto& r : rows) {
    std::string line = fmt::format("{}: surface distance median {:.3f} mm", r["subject"].get<std::string>(),
                                   r["surface_distance_mm"]["median"].get<double>());
    if (r.contains("correspondence_error_mm")) {
      line += fmt::format(", correspondence error median {:.3f} / p95 {:.3f} mm",
                          r["correspondence_error_mm"]["median"].get<double>(), r["correspondence_error_mm"]["p95"].get<double>());
    }
    if (r.contains("landmark_error_mm")) line += fmt::format(", landmarks {:.2f} mm", r["landmark_error_mm"]["mean"].get<double>());
    if (r.contains("maps") && r["maps"].contains("vs_truth")) {
      line += fmt::format(", diffuse PSNR {:.1f} dB, normals {:.2f} deg", r["maps"]["vs_truth"]["diffuse_psnr_db"].get<double>(),
                          r["maps"]["vs_truth"]["normal_angle_median_deg"].get<double>());
    }
    spdlog::info("{}, {:.1f} s", line, r["seconds"]["total"].get<double>());
  }
  if (!failures.empty()) {
    for (const auto& [dir, why] : failures) spdlog::error("{}: {}", dir, why);
    throw InvalidInput(args.scans, std::to_string(failures.size()) + " scan(s) failed (listed above and in summary.json)",
                       "fix them and rerun: registered scans are skipped");
  }
  std::vector<std::string> registered;
  for (const std::string& d : dirs) registered.push_back(args.output + "/" + fs::path(d).filename().string());
  return registered;
}

CLI::App* add_scan_register(CLI::App& scan, const Globals& globals, std::function<void()>& action) {
  auto args = std::make_shared<RegisterArgs>();
  CLI::App* app = scan.add_subcommand("register", "Register the template onto every scan (landmarks + NICP), with a report");
  app->add_option("--scans", args->scans, "Folder of scan folders (mesh.obj|ply, landmarks.json; truth/ is used if there)")
      ->capture_default_str();
  app->add_option("-o,--output", args->output, "Output folder: <id>/{mesh.ply, maps, report.json, qa_*.png}, summary.json")
      ->capture_default_str();
  app->add_option("--template", args->template_dir, "Template folder from 'bareskin template'")->capture_default_str();
  app->add_flag("--keep-going", args->keep_going, "Go on after a scan fails; list the failures at the end");
  app->add_flag("--no-landmarks", args->no_landmarks, "Ignore landmarks: fallback alignment (centroid + similarity ICP)");
  app->add_option("--stiffness", args->nicp.stiffness, "NICP stiffness schedule")->capture_default_str()->group("NICP");
  app->add_option("--landmark-weight", args->nicp.landmark_weight, "Landmark weight per step")
      ->capture_default_str()->group("NICP");
  app->add_option("--trim", args->nicp.trim_mm, "Correspondence distance trim per step (mm)")
      ->capture_default_str()->group("NICP");
  app->add_option("--nodes", args->nicp.nodes, "NICP node count (template remeshed; 0: every template vertex)")
      ->capture_default_str()->group("NICP");
  app->add_option("--iterations", args->nicp.iterations_per_step, "ICP iterations per stiffness step")
      ->capture_default_str()->group("NICP");
  app->add_option("--max-normal-angle", args->nicp.max_normal_angle_deg, "Reject correspondences beyond this angle")
      ->capture_default_str()->group("NICP");
  app->add_option("--consistency", args->nicp.consistency,
                  "Stiffness: weight of neighbouring affines agreeing at the nodes")
      ->capture_default_str()
      ->group("NICP");
  app->add_option("--affine-stiffness", args->nicp.affine_stiffness,
                  "Stiffness: weight of Amberg's affine difference (--consistency 0 --affine-stiffness 1: Amberg's)")
      ->capture_default_str()
      ->group("NICP");
  app->add_option("--huber", args->nicp.huber_mm, "Robust loss threshold (mm)")->capture_default_str()->group("NICP");
  app->add_option("--maps-res", args->maps.resolution,
                  "Transfer the scan's four maps into the template UV at this resolution (0: no maps)")
      ->capture_default_str()->group("Maps");
  app->add_option("--map-format", args->map_format, "png, tif or exr")->capture_default_str()->group("Maps");
  app->add_option("--heat-max", args->heat_max_mm, "Error (mm) shown red in the QA heat maps")->capture_default_str();
  action = [args, &globals] {
    args->nicp.check();
    args->maps.format = parse_map_format(args->map_format);
    if (args->maps.resolution != 0) args->maps.check();
    const TemplateFace face = read_template(args->template_dir + "/face.obj", args->template_dir + "/landmarks.json");
    register_folder(face, *args, globals);
  };
  return app;
}

}  // namespace bareskin::cli
