// The coefficient file: a face as the morphable model's coefficients. `mm-fit` writes it; `render`, `uvtools unwarp`
// and `uvtools mask` (--model --coeffs) and the trainers read it. JSON (docs/file_formats.md):
//   "alpha", "beta", "delta": identity, expression and appearance coefficients in standard deviations (any length up
//                             to the model's; missing ones are 0);
//   "rotation": [rx, ry, rz] radians, applied as Rz·Ry·Rx (euler_rotation); "translation": [tx, ty, tz] mm;
//   "gamma": 27 SH lighting coefficients (9 per colour channel, Deep3DFaceRecon's order); absent: no lighting.
// Every entry is optional. Other keys (a fit's diagnostics) are kept as they are in `extra`.
#pragma once
#include <Eigen/Core>
#include <array>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "core/image.h"
#include "core/mesh.h"
#include "morphable/model.h"

namespace bareskin {

struct Coefficients {
  Eigen::VectorXd alpha, beta, delta;
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero(), translation = Eigen::Vector3d::Zero();
  std::optional<std::array<double, 27>> gamma;
  nlohmann::json extra = nlohmann::json::object();
};

// Pose applied to model points: R(rotation) p + translation, R = Rz(rz) Ry(ry) Rx(rx).
Eigen::Matrix3d euler_rotation(const Eigen::Vector3d& angles);

// InvalidInput naming the file when it is not a JSON object or an entry is not a list of finite numbers of the
// right length (rotation, translation 3; gamma 27); IoError when it cannot be read.
Coefficients read_coefficients(const std::string& path);
// The same from the file's text; `path` only names it in errors.
Coefficients parse_coefficients(const std::string& text, const std::string& path);

// Writes the file atomically: the coefficients, then the `extra` keys.
void write_coefficients(const std::string& path, const Coefficients& c);

// The model at the coefficients: its topology (with UVs), vertices posed by rotation and translation, no normals.
Mesh posed_mesh(const MorphableModel& model, const Coefficients& c);

// The model's albedo at delta: an R x R linear RGB image (empty when the model has no appearance part).
Image appearance_image(const MorphableModel& model, const Coefficients& c);

}  // namespace bareskin
