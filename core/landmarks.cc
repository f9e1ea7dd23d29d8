#include "core/landmarks.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/files.h"
#include "core/error.h"

namespace bareskin {
namespace {

void check_points(const Landmarks& lm, const std::string& source) {
  if (lm.points.rows() == 0) throw InvalidInput(source, "has no landmark points", "");
  if (!lm.points.allFinite()) throw InvalidInput(source, "has a NaN or infinite landmark coordinate", "");
  if (lm.scheme == "ibug68" && lm.points.rows() != kIbug68Count) {
    throw InvalidInput(source, "has " + std::to_string(lm.points.rows()) + " landmarks, iBUG-68 needs 68",
                       "give all 68 points in iBUG order");
  }
}

}  // namespace

Landmarks parse_landmarks_json(const std::string& text, const std::string& source) {
  nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  if (doc.is_discarded()) throw InvalidInput(source, "is not valid JSON", "check the file (truncated?)");
  if (!doc.is_object() || !doc.contains("points") || !doc["points"].is_array()) {
    throw InvalidInput(source, "has no \"points\" array", R"(expected {"scheme":"ibug68","points":[[x,y] or [x,y,z],...]})");
  }
  Landmarks lm;
  if (doc.contains("scheme")) {
    if (!doc["scheme"].is_string()) throw InvalidInput(source, "\"scheme\" must be a string", "");
    lm.scheme = doc["scheme"].get<std::string>();
  }
  if (doc.contains("units")) {
    if (!doc["units"].is_string()) throw InvalidInput(source, "\"units\" must be a string", "");
    lm.units = doc["units"].get<std::string>();
  }
  const auto& pts = doc["points"];
  int dims = 0;
  lm.points.resize(Eigen::Index(pts.size()), 3);
  for (size_t i = 0; i < pts.size(); ++i) {
    const auto& p = pts[i];
    const int d = p.is_array() ? int(p.size()) : 0;
    if (d != 2 && d != 3) {
      throw InvalidInput(source, "landmark " + std::to_string(i) + " is not [x, y] or [x, y, z]", "");
    }
    if (dims == 0) dims = d;
    if (d != dims) throw InvalidInput(source, "landmarks mix 2D and 3D points (point " + std::to_string(i) + ")", "");
    for (int k = 0; k < d; ++k) {
      if (!p[k].is_number()) throw InvalidInput(source, "landmark " + std::to_string(i) + " has a non-number", "");
      lm.points(Eigen::Index(i), k) = p[k].get<double>();
    }
  }
  lm.points.conservativeResize(Eigen::NoChange, dims == 0 ? 3 : dims);
  check_points(lm, source);
  return lm;
}

Landmarks parse_landmarks_pts(const std::string& text, const std::string& source) {
  std::istringstream in(text);
  std::string word;
  int count = -1;
  while (in >> word && word != "{") {
    if (word == "n_points:") {
      if (!(in >> count) || count <= 0 || count > 100000) throw InvalidInput(source, "bad n_points", "");
    }
  }
  if (word != "{" || count < 0) throw InvalidInput(source, "is not an iBUG .pts file (no n_points / '{')", "");
  Landmarks lm;
  lm.units = "px";
  lm.points.resize(count, 2);
  for (int i = 0; i < count; ++i) {
    if (!(in >> lm.points(i, 0) >> lm.points(i, 1))) {
      throw InvalidInput(source, "ends after " + std::to_string(i) + " of " + std::to_string(count) + " points",
                         "the file is truncated");
    }
  }
  if (!(in >> word) || word != "}") throw InvalidInput(source, "has no closing '}' after the points", "");
  lm.scheme = count == kIbug68Count ? "ibug68" : "custom";
  check_points(lm, source);
  return lm;
}

Landmarks read_landmarks(const std::string& path) {
  const std::string ext = lower_extension(path);
  const std::string text = read_file(path);
  if (ext == ".json") return parse_landmarks_json(text, path);
  if (ext == ".pts") return parse_landmarks_pts(text, path);
  throw InvalidInput(path, "unknown landmark format '" + ext + "'", "use .json or .pts");
}

Landmarks read_image_landmarks(const std::string& path, int width, int height) {
  Landmarks lm = read_landmarks(path);
  if (lm.points.rows() != kIbug68Count || lm.points.cols() != 2) {
    throw InvalidInput(path, "needs 68 2D landmarks, has " + std::to_string(lm.points.rows()) + " of " +
                                 std::to_string(lm.points.cols()) + "D", "give the 68 iBUG points in pixels");
  }
  const double size = std::max(width, height);
  if (!((lm.points.array() >= -size).all() && (lm.points.array() <= 2 * size).all())) {
    throw InvalidInput(path, "has points far outside the " + std::to_string(width) + "x" + std::to_string(height) +
                                 " image", "give the 68 iBUG points in the image's pixels");
  }
  return lm;
}

void write_landmarks(const std::string& path, const Landmarks& lm) {
  check_points(lm, path);
  const std::string ext = lower_extension(path);
  std::ostringstream out;
  out.precision(10);
  if (ext == ".pts") {
    if (lm.points.cols() != 2) throw InvalidInput(path, ".pts holds 2D points only", "write .json for 3D landmarks");
    out << "version: 1\nn_points: " << lm.points.rows() << "\n{\n";
    for (Eigen::Index i = 0; i < lm.points.rows(); ++i) out << lm.points(i, 0) << " " << lm.points(i, 1) << "\n";
    out << "}\n";
  } else if (ext == ".json") {
    nlohmann::json doc;
    doc["scheme"] = lm.scheme;
    if (!lm.units.empty()) doc["units"] = lm.units;
    doc["points"] = nlohmann::json::array();
    for (Eigen::Index i = 0; i < lm.points.rows(); ++i) {
      auto p = nlohmann::json::array();
      for (Eigen::Index k = 0; k < lm.points.cols(); ++k) p.push_back(lm.points(i, k));
      doc["points"].push_back(p);
    }
    out << doc.dump(1) << "\n";
  } else {
    throw InvalidInput(path, "unknown landmark format '" + ext + "'", "use .json or .pts");
  }
  write_file_atomic(path, out.str());
}

}  // namespace bareskin
