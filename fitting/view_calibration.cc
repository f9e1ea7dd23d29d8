#include "fitting/view_calibration.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/stats.h"

namespace bareskin::texgen {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const char* const kKind = "bareskin texgen view landmark calibration";

Eigen::Matrix<double, 68, 2> points_of(const json& j, const std::string& file, const std::string& field) {
  if (!j.is_array() || j.size() != 68)
    throw InvalidInput(file, "has no " + field + " (68 points) per view",
                       "make the reports with this version of `texgen make-dataset`");
  Eigen::Matrix<double, 68, 2> p;
  for (int k = 0; k < 68; ++k)
    for (int c = 0; c < 2; ++c) p(k, c) = j[size_t(k)].at(size_t(c)).get<double>();
  return p;
}

// The residuals (detected − true, per render size) of one view (name, yaw) over the reports.
struct Sums {
  std::string name;
  double yaw_deg = 0;
  std::vector<Eigen::Matrix<double, 68, 2>> residuals;
};

}  // namespace

const ViewCalibration::View& ViewCalibration::at(const std::string& name, double yaw_deg, const std::string& source) const {
  for (const View& v : views)
    if (v.name == name && std::abs(v.yaw_deg - yaw_deg) < 1e-6) return v;
  std::ostringstream yaw;
  yaw << yaw_deg;
  throw InvalidInput(source, "has no " + name + " view at yaw " + yaw.str() + "°",
                     "learn it from reports made with the same --yaw-left/--yaw-right");
}

Eigen::Matrix<double, 68, 2> calibrated_landmarks(const Eigen::Matrix<double, 68, 2>& detected,
                                                  const ViewCalibration::View& view, int render_size) {
  return detected - view.bias * double(render_size);
}

std::vector<std::string> report_files(const std::string& dataset_folder) {
  std::vector<std::string> files;
  const std::string dir = dataset_folder + "/reports";
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".json") files.push_back(e.path().string());
  std::sort(files.begin(), files.end());
  return files;
}

ViewCalibration learn_view_calibration(const std::vector<std::string>& files) {
  if (files.empty()) throw InvalidInput("--write-view-calibration", "no make-dataset reports to learn from",
                                         "run make-dataset over training subjects first (their reports/ folder)");
  std::vector<Sums> sums;
  ViewCalibration out;
  bool first = true;
  for (const std::string& file : files) {
    json report;
    try {
      report = json::parse(read_file(file));
    } catch (const json::exception& e) {
      throw InvalidInput(file, std::string("is not a make-dataset report: ") + e.what(),
                         "remove it from reports/, or run make-dataset again");
    }
    if (!report.contains("lights")) throw InvalidInput(file, "is not a make-dataset report (no lights)",
                                                          "remove it from reports/, or run make-dataset again");
    for (const json& light : report["lights"]) {
      const std::string calibration = light.value("landmark_calibration", "");
      if (first) out.landmark_calibration = calibration;
      first = false;
      if (calibration != out.landmark_calibration)
        throw InvalidInput(file, "was made with the 3D calibration '" + calibration + "', other reports with '" +
                                     out.landmark_calibration + "'",
                           "learn from reports of one --landmark-calibration");
      const double size = light.at("sizes").at("render").get<double>();
      for (const json& v : light.at("views")) {
        if (!v.contains("landmarks_detected_px") || !v.contains("landmarks_truth_px"))
          throw InvalidInput(file, "has no detected and true landmarks per view",
                             "make the reports with this version of `texgen make-dataset`");
        const std::string name = v.at("name").get<std::string>();
        const double yaw = v.at("yaw_deg").get<double>();
        const Eigen::Matrix<double, 68, 2> r =
            (points_of(v["landmarks_detected_px"], file, "landmarks_detected_px") -
             points_of(v["landmarks_truth_px"], file, "landmarks_truth_px")) / size;
        auto it = std::find_if(sums.begin(), sums.end(),
                               [&](const Sums& s) { return s.name == name && std::abs(s.yaw_deg - yaw) < 1e-6; });
        if (it == sums.end()) it = sums.insert(sums.end(), Sums{name, yaw, {}});
        it->residuals.push_back(r);
      }
    }
  }
  for (const Sums& s : sums) {
    if (s.residuals.size() < 2)
      throw InvalidInput(files.front(), "gives the " + s.name + " view only once", "learn from two subjects at least");
    ViewCalibration::View v;
    v.name = s.name;
    v.yaw_deg = s.yaw_deg;
    v.samples = int(s.residuals.size());
    // The median per coordinate: a view on which the detector collapsed (hundreds of px off) leaves it in place.
    std::vector<double> values(s.residuals.size());
    for (int k = 0; k < 68; ++k)
      for (int c = 0; c < 2; ++c) {
        for (size_t i = 0; i < values.size(); ++i) values[i] = s.residuals[i](k, c);
        v.bias(k, c) = median(values);
      }
    for (const auto& r : s.residuals) v.scatter += (r - v.bias).rowwise().squaredNorm() / double(s.residuals.size());
    v.scatter = v.scatter.cwiseSqrt();
    out.views.push_back(v);
  }
  return out;
}

void write_view_calibration(const std::string& path, const ViewCalibration& c) {
  json views = json::array();
  for (const ViewCalibration::View& v : c.views) {
    json bias = json::array(), scatter = json::array();
    for (int k = 0; k < 68; ++k) {
      bias.push_back({v.bias(k, 0), v.bias(k, 1)});
      scatter.push_back(v.scatter(k));
    }
    views.push_back({{"name", v.name}, {"yaw_deg", v.yaw_deg}, {"samples", v.samples}, {"bias", bias},
                     {"scatter_rms", scatter}});
  }
  const json j = {{"kind", kKind},
                  {"unit", "fraction of the render size; detected − true landmark (x right, y down)"},
                  {"landmark_calibration", c.landmark_calibration},
                  {"views", views}};
  write_file_atomic(path, j.dump(1) + "\n");
}

ViewCalibration read_view_calibration(const std::string& path) {
  json j;
  try {
    j = json::parse(read_file(path));
  } catch (const json::exception& e) {
    throw InvalidInput(path, std::string("is not JSON: ") + e.what(), "make it with make-dataset --write-view-calibration");
  }
  if (j.value("kind", "") != kKind)
    throw InvalidInput(path, "is not a view calibration", "make it with make-dataset --write-view-calibration");
  ViewCalibration c;
  c.landmark_calibration = j.value("landmark_calibration", "");
  try {
    for (const json& v : j.at("views")) {
      ViewCalibration::View view;
      view.name = v.at("name").get<std::string>();
      view.yaw_deg = v.at("yaw_deg").get<double>();
      view.samples = v.value("samples", 0);
      view.bias = points_of(v.at("bias"), path, "bias");
      const json& s = v.at("scatter_rms");
      for (int k = 0; k < 68 && k < int(s.size()); ++k) view.scatter(k) = s[size_t(k)].get<double>();
      if (!view.bias.allFinite())
        throw InvalidInput(path, "has non-finite offsets", "learn it again with make-dataset --write-view-calibration");
      c.views.push_back(view);
    }
  } catch (const json::exception& e) {
    throw InvalidInput(path, std::string("is not a view calibration: ") + e.what(),
                       "make it with make-dataset --write-view-calibration");
  }
  return c;
}

}  // namespace bareskin::texgen
