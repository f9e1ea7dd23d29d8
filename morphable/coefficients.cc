#include "morphable/coefficients.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/error.h"
#include "core/files.h"

namespace bareskin {

Eigen::Matrix3d euler_rotation(const Eigen::Vector3d& a) {
  return (Eigen::AngleAxisd(a.z(), Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(a.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a.x(), Eigen::Vector3d::UnitX())).toRotationMatrix();
}

namespace {

const char* const kKeys[] = {"alpha", "beta", "delta", "rotation", "translation", "gamma"};

// doc[key] as numbers: absent -> empty; InvalidInput unless a list of finite numbers (of `expected` length if > 0).
std::vector<double> numbers(const nlohmann::json& doc, const char* key, size_t expected, const std::string& path) {
  std::vector<double> v;
  if (!doc.contains(key)) return v;
  if (!doc[key].is_array()) throw InvalidInput(path, std::string(key) + " is not a list", "write a list of numbers");
  for (const auto& x : doc[key]) {
    if (!x.is_number() || !std::isfinite(x.get<double>())) {
      throw InvalidInput(path, std::string(key) + " holds a value that is not a finite number", "write finite numbers");
    }
    v.push_back(x.get<double>());
  }
  if (expected && v.size() != expected) {
    throw InvalidInput(path, std::string(key) + " needs " + std::to_string(expected) + " numbers, has " +
                                 std::to_string(v.size()), "");
  }
  return v;
}

Eigen::VectorXd vector(const std::vector<double>& v) {
  return Eigen::Map<const Eigen::VectorXd>(v.data(), Eigen::Index(v.size()));
}

std::vector<double> list(const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); }

}  // namespace

Coefficients read_coefficients(const std::string& path) { return parse_coefficients(read_file(path), path); }

Coefficients parse_coefficients(const std::string& text, const std::string& path) {
  const auto doc = nlohmann::json::parse(text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) {
    throw InvalidInput(path, "is not a JSON object", "give the coefficient file mm-fit writes");
  }
  // {} is the mean face at the default pose; keys but none of ours is another file (e.g. landmarks).
  if (!doc.empty() && std::none_of(std::begin(kKeys), std::end(kKeys), [&](const char* k) { return doc.contains(k); })) {
    throw InvalidInput(path, "holds no coefficients (alpha, beta, delta, gamma, rotation or translation)",
                       "give the coefficient file mm-fit or recon writes ({} for the mean face)");
  }
  Coefficients c;
  c.alpha = vector(numbers(doc, "alpha", 0, path));
  c.beta = vector(numbers(doc, "beta", 0, path));
  c.delta = vector(numbers(doc, "delta", 0, path));
  if (const auto r = numbers(doc, "rotation", 3, path); !r.empty()) c.rotation = Eigen::Vector3d(r[0], r[1], r[2]);
  if (const auto t = numbers(doc, "translation", 3, path); !t.empty()) c.translation = Eigen::Vector3d(t[0], t[1], t[2]);
  if (const auto g = numbers(doc, "gamma", 27, path); !g.empty()) {
    std::array<double, 27> gamma{};
    std::copy(g.begin(), g.end(), gamma.begin());
    c.gamma = gamma;
  }
  for (const auto& [key, value] : doc.items()) {
    if (std::find(std::begin(kKeys), std::end(kKeys), key) == std::end(kKeys)) c.extra[key] = value;
  }
  return c;
}

void write_coefficients(const std::string& path, const Coefficients& c) {
  nlohmann::json j = {{"alpha", list(c.alpha)},
                      {"beta", list(c.beta)},
                      {"rotation", {c.rotation.x(), c.rotation.y(), c.rotation.z()}},
                      {"translation", {c.translation.x(), c.translation.y(), c.translation.z()}}};
  if (c.delta.size() > 0) j["delta"] = list(c.delta);
  if (c.gamma) j["gamma"] = *c.gamma;
  for (const auto& [key, value] : c.extra.items()) j[key] = value;
  write_file_atomic(path, j.dump(1) + "\n");
}

}  // namespace bareskin
