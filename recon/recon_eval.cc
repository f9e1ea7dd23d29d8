// bareskin recon --eval: a trained F/E on held-out face samples against their truth, side by side with mm-fit's
// landmark fitter on the same faces (speed against accuracy), the failure curves over yaw and expression, and how well
// the confidence flags bad answers. Writes metrics.json, faces.csv, speed.csv, charts (SVG) and heat-map strips.
#include "recon/recon_eval.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <numeric>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/svg_chart.h"
#include "detect/face_api.h"
#include "morphable/fit.h"
#include "morphable/model.h"
#include "training/identity.h"

namespace bareskin::recon {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
constexpr double kNan = std::numeric_limits<double>::quiet_NaN();

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

double quantile(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return kNan;
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const size_t i = size_t(pos);
  return i + 1 < v.size() ? v[i] + (pos - double(i)) * (v[i + 1] - v[i]) : v[i];
}

double mean(const std::vector<double>& v) {
  double s = 0;
  int n = 0;
  for (double x : v) {
    if (std::isfinite(x)) s += x, ++n;
  }
  return n ? s / n : kNan;
}

Image to_image(const torch::Tensor& chw) {
  const torch::Tensor t = chw.detach().to(torch::kCPU, torch::kFloat).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image img(int(t.size(1)), int(t.size(0)), int(t.size(2)), ColorSpace::sRGB);
  std::memcpy(img.pixels.data(), t.data_ptr<float>(), img.pixels.size() * sizeof(float));
  return img;
}

// Per-vertex distances [V] between two shapes, as they are and after the best similarity (Umeyama).
std::pair<Eigen::VectorXd, Eigen::VectorXd> vertex_errors(const torch::Tensor& a, const torch::Tensor& b) {
  const torch::Tensor ad = a.to(torch::kCPU, torch::kDouble).contiguous(), bd = b.to(torch::kCPU, torch::kDouble).contiguous();
  const int64_t V = ad.size(0);
  const Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic>> A(ad.data_ptr<double>(), 3, V), B(bd.data_ptr<double>(), 3, V);
  const Eigen::VectorXd raw = (A - B).colwise().norm().transpose();
  const Eigen::Matrix4d T = Eigen::umeyama(A, B, true);
  const Eigen::Matrix<double, 3, Eigen::Dynamic> At = (T.topLeftCorner<3, 3>() * A).colwise() + T.topRightCorner<3, 1>();
  return {raw, (At - B).colwise().norm().transpose()};
}

// A blue → green → yellow → red ramp over [0, top] mm.
std::array<float, 3> ramp(double mm, double top) {
  const double t = std::clamp(mm / top, 0.0, 1.0);
  const double stops[4][3] = {{0.1, 0.2, 0.8}, {0.1, 0.75, 0.3}, {0.95, 0.85, 0.1}, {0.85, 0.1, 0.1}};
  const double s = t * 3;
  const int i = std::min(2, int(s));
  const double f = s - i;
  return {float(stops[i][0] * (1 - f) + stops[i + 1][0] * f), float(stops[i][1] * (1 - f) + stops[i + 1][1] * f),
          float(stops[i][2] * (1 - f) + stops[i + 1][2] * f)};
}

// The per-vertex error painted on the predicted face as the canonical camera sees it, over black.
torch::Tensor heat_map(const recon::FaceRender& render, const recon::FaceModel& model, const Eigen::VectorXd& err,
                       double top, int64_t size) {
  torch::Tensor colour = torch::empty({1, err.size(), 3});
  for (int64_t v = 0; v < err.size(); ++v) {
    const auto c = ramp(err(v), top);
    for (int k = 0; k < 3; ++k) colour[0][v][k] = c[size_t(k)];
  }
  const torch::Tensor pos = render.projected.to(torch::kCPU, torch::kFloat);
  const torch::Tensor tri = model.triangles().to(torch::kCPU);
  const render_torch::Raster r = render_torch::rasterize(pos, tri, size, size);
  return render_torch::interpolate(colour, pos, tri, r)[0].permute({2, 0, 1});
}

std::string fmt(double v, int digits = 3) {
  if (!std::isfinite(v)) return "";
  std::ostringstream s;
  s.precision(digits);
  s << std::fixed << v;
  return s.str();
}

}  // namespace

void EvalOptions::check() const {
  if (data.empty() || run.empty() || output.empty())
    throw InvalidInput("recon --eval", "needs the samples, the run and an output folder", "give --eval, --run and -o");
  if (input != "before" && input != "makeup")
    throw InvalidInput("--eval-input", "'" + input + "' is not a member the net can see", "use before or makeup");
  if (max_faces < 0) throw InvalidInput("--eval-faces", "must not be negative", "0 takes every sample");
  if (heat_maps < 0) throw InvalidInput("recon --eval", "the heat-map count must not be negative", "e.g. 4");
  if (fit_iterations.empty()) throw InvalidInput("recon --eval", "no mm-fit iteration count is given", "e.g. 1, 5, 20");
  for (int k : fit_iterations)
    if (k < 1 || k > 1000) throw InvalidInput("recon --eval", "mm-fit iteration counts must lie in [1, 1000]", "");
  if (!(bad_mm > 0)) throw InvalidInput("recon --eval", "the bad shape error must be > 0 mm", "e.g. 3");
  confidence.check();
}

nlohmann::json evaluate_recon(const EvalOptions& o, const ProgressCallback& progress) {
  o.check();
  const std::string model = recon::run_model_path(o.run, o.model);
  const recon::FaceModel face_model = recon::FaceModel::load(model);
  const recon::TrainedRecon net = recon::load_recon(o.run, face_model, torch::kCPU);
  const MorphableModel geometry = read_model(model);
  const detect::FaceApi detector(detect::default_face_api_folder());
  std::shared_ptr<detect::FaceRecognitionNet> identity;
  if (o.identity) {
    identity = std::make_shared<detect::FaceRecognitionNet>(detect::default_face_api_folder());
    (*identity)->eval();
  }
  data::LoaderOptions lo;
  lo.dataset = o.data;
  lo.required = {o.input + ".png", "json"};
  lo.batch_size = 1;
  lo.shuffle_buffer = 0;
  lo.decode_threads = 1;
  data::ShardLoader loader(lo);
  int64_t count = loader.epoch_size();
  if (o.max_faces > 0) count = std::min<int64_t>(count, o.max_faces);
  const int64_t S = net.image_size;
  const Camera cam = recon::canonical_camera(int(S));
  const recon::CoefficientLayout layout = face_model.layout(true);
  AtomicDirectory folder(o.output);  // the evaluation's folder appears whole or not at all
  const std::string out = folder.path();
  fs::create_directories(out + "/img");

  struct Face {
    std::string key;
    double yaw = 0, expression = 0, shape = 0, shape_aligned = 0, landmark = 0, psnr = 0, gamma = 0, alpha = 0,
           beta = 0, delta = 0, rotation = 0, mean_face = 0, identity = kNan, confidence = 0, residual = kNan, net_ms = 0;
    bool flagged = false, detected = false;
    std::vector<double> fit_ms, fit_mm, refine_ms, refine_mm, truth_ms, truth_mm;
  };
  std::vector<Face> faces;
  std::vector<double> pooled, pooled_aligned;
  std::vector<torch::Tensor> strips;
  for (int64_t i = 0; i < count; ++i) {
    const data::Batch batch = loader.next();
    const recon::ReconTargets t = recon::resized(recon::targets_from_batch(batch, face_model, o.input), S);
    if (t.has_truth[0].item<double>() == 0) continue;
    Face f;
    f.key = batch.keys[0];
    const torch::Tensor image = t.image[0];
    // The detector on the aligned face, as on a photo.
    // An aligned face fills its frame; the detector wants context, so it looks at it on a black canvas twice as large.
    const int64_t pad = S / 2;
    const torch::Tensor canvas = torch::constant_pad_nd(image, {pad, pad, pad, pad}, 0);
    detect::DetectOptions dopt;
    dopt.min_score = 0.3;
    std::vector<detect::Face> found = detector.detect(detect::photo_tensor(to_image(canvas), f.key), dopt);
    for (detect::Face& d : found) d.points.array() -= double(pad);
    torch::Tensor det;
    Eigen::MatrixX2d det_lm(68, 2), true_lm(68, 2);
    const torch::Tensor tl = t.landmarks[0].to(torch::kDouble);
    for (int k = 0; k < 68; ++k) true_lm(k, 0) = tl[k][0].item<double>(), true_lm(k, 1) = tl[k][1].item<double>();
    if (!found.empty()) {
      f.detected = true;
      det = torch::empty({68, 2}, torch::kDouble);
      for (int k = 0; k < 68; ++k) {
        det[k][0] = det_lm(k, 0) = found[0].points(k, 0);
        det[k][1] = det_lm(k, 1) = found[0].points(k, 1);
      }
    }
    const recon::Reconstruction r = recon::reconstruct(net, image, det, o.confidence);
    const torch::Tensor pred = r.coefficients.unsqueeze(0);
    const auto m = recon::recon_metrics(face_model, pred, t, S);
    f.net_ms = r.milliseconds;
    f.landmark = m.at("landmark_px")[0];
    f.psnr = m.at("skin_psnr")[0];
    f.gamma = m.at("gamma_rmse")[0];
    f.alpha = m.at("alpha_sigma")[0];
    f.beta = m.at("beta_sigma")[0];
    f.delta = m.at("delta_sigma")[0];
    f.rotation = m.at("rotation_deg")[0];
    f.confidence = r.confidence;
    f.flagged = r.flagged;
    f.residual = r.landmark_residual_px;
    const recon::FaceCoefficients p = face_model.split(pred), q = face_model.split(t.truth);
    f.yaw = q.rotation[0][1].item<double>() * 180 / M_PI;
    f.expression = q.beta.numel() ? q.beta.pow(2).mean().sqrt().item<double>() : 0;
    const torch::Tensor truth_shape = face_model.shape(q.alpha, q.beta)[0];
    const auto [raw, aligned] = vertex_errors(face_model.shape(p.alpha, p.beta)[0], truth_shape);
    f.shape = raw.mean();
    f.shape_aligned = aligned.mean();
    const torch::Tensor zero = torch::zeros({1, layout.id}), zero_b = torch::zeros({1, layout.exp});
    f.mean_face = vertex_errors(face_model.shape(zero, zero_b)[0], truth_shape).first.mean();
    for (Eigen::Index v = 0; v < raw.size(); v += 7) pooled.push_back(raw(v)), pooled_aligned.push_back(aligned(v));
    if (identity) {
      torch::NoGradGuard guard;
      f.identity = 1 - losses::identity_distance(*identity, r.overlay.unsqueeze(0), image.unsqueeze(0))[0].item<double>();
    }
    // mm-fit's landmark fitter from the mean face, and from the net's answer, for growing iteration counts.
    const auto shape_error = [&](const LandmarkFit& fit) {
      torch::Tensor c = torch::zeros({1, layout.size()});
      for (Eigen::Index j = 0; j < fit.alpha.size(); ++j) c[0][j] = fit.alpha(j);
      for (Eigen::Index j = 0; j < fit.beta.size(); ++j) c[0][layout.id + j] = fit.beta(j);
      const recon::FaceCoefficients fc = face_model.split(c);
      return vertex_errors(face_model.shape(fc.alpha, fc.beta)[0], truth_shape).first.mean();
    };
    LandmarkFit start;
    start.alpha = Eigen::VectorXd(layout.id), start.beta = Eigen::VectorXd(layout.exp);
    for (int64_t j = 0; j < layout.id; ++j) start.alpha(j) = p.alpha[0][j].item<double>();
    for (int64_t j = 0; j < layout.exp; ++j) start.beta(j) = p.beta[0][j].item<double>();
    for (int k = 0; k < 3; ++k) {
      start.rotation(k) = p.rotation[0][k].item<double>();
      start.translation(k) = p.translation[0][k].item<double>();
    }
    for (int iterations : o.fit_iterations) {
      LandmarkFitOptions fo;
      fo.shape_components = int(layout.id);
      fo.expression_components = int(layout.exp);
      fo.iterations = iterations;
      auto t0 = Clock::now();
      const LandmarkFit upper = fit_landmarks(geometry, true_lm, cam, fo);  // the true landmarks: a bound
      f.truth_ms.push_back(ms_since(t0));
      f.truth_mm.push_back(shape_error(upper));
      if (!f.detected) {  // mm-fit needs the detector's landmarks, as on a photo
        for (auto* v : {&f.fit_ms, &f.fit_mm, &f.refine_ms, &f.refine_mm}) v->push_back(kNan);
        continue;
      }
      t0 = Clock::now();
      const LandmarkFit scratch = fit_landmarks(geometry, det_lm, cam, fo);
      f.fit_ms.push_back(ms_since(t0));
      f.fit_mm.push_back(shape_error(scratch));
      fo.start = &start;
      t0 = Clock::now();
      const LandmarkFit refined = fit_landmarks(geometry, det_lm, cam, fo);
      f.refine_ms.push_back(f.net_ms + ms_since(t0));
      f.refine_mm.push_back(shape_error(refined));
    }
    if (int64_t(strips.size()) < o.heat_maps) {
      const recon::FaceRender fr = face_model.render(pred, cam);
      const torch::Tensor heat = heat_map(fr, face_model, raw, 5.0, S);
      strips.push_back(torch::cat({image, r.overlay, heat}, 2));
    }
    faces.push_back(f);
    report(progress, i + 1, count, f.key);
  }
  if (faces.empty()) throw InvalidInput(o.data, "holds no samples with truth coefficients", "give a split of 'texgen faces'");

  // Confidence against shape error > 3 mm: the flag's rates, and the best detection rate at ≤ 10% false alarms.
  std::vector<double> bad_scores, good_scores;
  int flagged_bad = 0, flagged_good = 0;
  for (const Face& f : faces) {
    const bool bad = f.shape > o.bad_mm;
    (bad ? bad_scores : good_scores).push_back(1 - f.confidence);
    if (f.flagged) (bad ? flagged_bad : flagged_good)++;
  }
  double tpr_at_10 = kNan;
  if (!bad_scores.empty() && !good_scores.empty()) {
    const double thr = quantile(good_scores, 0.9);
    tpr_at_10 = double(std::count_if(bad_scores.begin(), bad_scores.end(), [&](double s) { return s > thr; })) /
                double(bad_scores.size());
  }
  const auto column = [&](double Face::*field) {
    std::vector<double> v;
    for (const Face& f : faces) v.push_back(f.*field);
    return v;
  };
  nlohmann::json summary = {
      {"faces", faces.size()},
      {"data", o.data},
      {"run", o.run},
      {"net", net.module},
      {"image_size", S},
      {"shape_mm", {{"median_per_vertex", quantile(pooled, 0.5)}, {"p95_per_vertex", quantile(pooled, 0.95)},
                    {"median_per_face", quantile(column(&Face::shape), 0.5)},
                    {"mean_face_median_per_face", quantile(column(&Face::mean_face), 0.5)}}},
      {"shape_aligned_mm", {{"median_per_vertex", quantile(pooled_aligned, 0.5)},
                            {"p95_per_vertex", quantile(pooled_aligned, 0.95)}}},
      {"landmark_px", {{"median", quantile(column(&Face::landmark), 0.5)}, {"mean", mean(column(&Face::landmark))}}},
      {"skin_psnr_db", {{"median", quantile(column(&Face::psnr), 0.5)}}},
      {"gamma_rmse", {{"median", quantile(column(&Face::gamma), 0.5)}}},
      {"alpha_sigma", quantile(column(&Face::alpha), 0.5)},
      {"beta_sigma", quantile(column(&Face::beta), 0.5)},
      {"delta_sigma", quantile(column(&Face::delta), 0.5)},
      {"rotation_deg", quantile(column(&Face::rotation), 0.5)},
      {"identity_cosine", quantile(column(&Face::identity), 0.5)},
      {"net_ms", {{"median", quantile(column(&Face::net_ms), 0.5)}}},
      {"confidence", {{"bad_mm", o.bad_mm}, {"bad", bad_scores.size()}, {"good", good_scores.size()},
                      {"flag_detection_rate", bad_scores.empty() ? kNan : double(flagged_bad) / bad_scores.size()},
                      {"flag_false_alarm_rate", good_scores.empty() ? kNan : double(flagged_good) / good_scores.size()},
                      {"detection_rate_at_10pct_false_alarms", tpr_at_10}}}};
  // Speed against accuracy: medians per iteration count.
  Chart speed{"Speed against accuracy (median over " + std::to_string(faces.size()) + " faces)", "milliseconds per face",
              "shape error, mm (mean per vertex)", {}, true, false};
  ChartSeries scratch{"mm-fit from the mean face (detector landmarks)", {}, {}},
      refined{"net, then mm-fit from its answer (detector landmarks)", {}, {}},
      upper{"mm-fit on the true landmarks (a bound)", {}, {}};
  ChartSeries mean_point{"the mean face (no fit)", {0.0}, {quantile(column(&Face::mean_face), 0.5)}};
  ChartSeries net_point{"net alone (one forward pass)", {quantile(column(&Face::net_ms), 0.5)},
                        {quantile(column(&Face::shape), 0.5)}};
  std::string speed_csv = "iterations,mmfit_ms,mmfit_mm,refine_ms,refine_mm,truth_landmarks_ms,truth_landmarks_mm\n";
  nlohmann::json speed_json = nlohmann::json::array();
  for (size_t k = 0; k < o.fit_iterations.size(); ++k) {
    std::vector<double> a, b, c, d, e, g;
    for (const Face& f : faces) {
      a.push_back(f.fit_ms[k]), b.push_back(f.fit_mm[k]), c.push_back(f.refine_ms[k]), d.push_back(f.refine_mm[k]);
      e.push_back(f.truth_ms[k]), g.push_back(f.truth_mm[k]);
    }
    upper.x.push_back(quantile(e, 0.5)), upper.y.push_back(quantile(g, 0.5));
    scratch.x.push_back(quantile(a, 0.5)), scratch.y.push_back(quantile(b, 0.5));
    refined.x.push_back(quantile(c, 0.5)), refined.y.push_back(quantile(d, 0.5));
    speed_csv += std::to_string(o.fit_iterations[k]) + "," + fmt(scratch.x.back()) + "," + fmt(scratch.y.back()) + "," +
                 fmt(refined.x.back()) + "," + fmt(refined.y.back()) + "," + fmt(upper.x.back()) + "," +
                 fmt(upper.y.back()) + "\n";
    speed_json.push_back({{"iterations", o.fit_iterations[k]}, {"mmfit_ms", scratch.x.back()}, {"mmfit_mm", scratch.y.back()},
                          {"refine_ms", refined.x.back()}, {"refine_mm", refined.y.back()},
                          {"truth_landmarks_ms", upper.x.back()}, {"truth_landmarks_mm", upper.y.back()}});
  }
  summary["speed"] = speed_json;
  summary["detected"] = std::count_if(faces.begin(), faces.end(), [](const Face& f) { return f.detected; });
  speed.series = {scratch, refined, upper, net_point, mean_point};
  // Failure curves: medians per yaw and expression bin.
  const auto binned = [&](double Face::*key, double width, int bins, const char* label, const char* x_label) {
    Chart c{std::string("Where it fails: error against ") + label, x_label, "median", {}, true, false};
    ChartSeries shape{"shape error, mm", {}, {}}, lm{"landmark RMS, px / 2", {}, {}};
    nlohmann::json rows = nlohmann::json::array();
    for (int b = 0; b < bins; ++b) {
      std::vector<double> s, l;
      for (const Face& f : faces) {
        const double k = std::abs(f.*key);
        if (k >= b * width && (k < (b + 1) * width || b == bins - 1)) s.push_back(f.shape), l.push_back(f.landmark);
      }
      if (s.empty()) continue;
      const double centre = (b + 0.5) * width;
      shape.x.push_back(centre), shape.y.push_back(quantile(s, 0.5));
      lm.x.push_back(centre), lm.y.push_back(quantile(l, 0.5) / 2);
      rows.push_back({{"from", b * width}, {"to", (b + 1) * width}, {"faces", s.size()}, {"shape_mm", quantile(s, 0.5)},
                      {"landmark_px", quantile(l, 0.5)}});
    }
    c.series = {shape, lm};
    return std::make_pair(c, rows);
  };
  const auto [yaw_chart, yaw_rows] = binned(&Face::yaw, 10, 6, "yaw", "|yaw|, degrees (bins of 10)");
  double top_expression = 0;
  for (const Face& f : faces) top_expression = std::max(top_expression, f.expression);
  const auto [exp_chart, exp_rows] = binned(&Face::expression, std::max(1e-6, top_expression / 5), 5, "expression",
                                            "expression strength (RMS β over all components, σ)");
  summary["by_yaw"] = yaw_rows;
  summary["by_expression"] = exp_rows;
  write_file_atomic(out + "/speed_accuracy.svg", svg_line_chart(speed));
  write_file_atomic(out + "/failure_yaw.svg", svg_line_chart(yaw_chart));
  write_file_atomic(out + "/failure_expression.svg", svg_line_chart(exp_chart));
  write_file_atomic(out + "/speed.csv", speed_csv);
  std::string csv = "key,yaw_deg,expression,shape_mm,shape_aligned_mm,landmark_px,skin_psnr_db,gamma_rmse,alpha_sigma,"
                    "beta_sigma,delta_sigma,rotation_deg,identity_cosine,net_ms,detected,residual_px,confidence,flagged\n";
  for (const Face& f : faces) {
    csv += f.key + "," + fmt(f.yaw, 1) + "," + fmt(f.expression) + "," + fmt(f.shape) + "," + fmt(f.shape_aligned) + "," +
           fmt(f.landmark) + "," + fmt(f.psnr, 2) + "," + fmt(f.gamma, 4) + "," + fmt(f.alpha) + "," + fmt(f.beta) + "," +
           fmt(f.delta) + "," + fmt(f.rotation) + "," + fmt(f.identity) + "," + fmt(f.net_ms, 1) + "," +
           (f.detected ? "1" : "0") + "," + fmt(f.residual) + "," + fmt(f.confidence, 4) + "," + (f.flagged ? "1" : "0") + "\n";
  }
  write_file_atomic(out + "/faces.csv", csv);
  if (!strips.empty()) write_image(out + "/img/heat_maps.png", to_image(torch::cat(strips, 1)));
  write_file_atomic(out + "/metrics.json", summary.dump(2) + "\n");
  folder.commit();
  return summary;
}

}  // namespace bareskin::recon
