// Facial landmarks: 2D (image pixels) or 3D (mm), in the iBUG-68 order unless the file names another scheme.
// Files: JSON {"scheme": "ibug68", "units": "mm"|"px", "points": [[x, y(, z)], ...]} or iBUG .pts (2D).
#pragma once
#include <Eigen/Core>
#include <string>

namespace bareskin {

constexpr int kIbug68Count = 68;

struct Landmarks {
  std::string scheme = "ibug68";
  std::string units;        // "mm" (3D on a mesh) or "px" (image, origin top-left, x right, y down)
  Eigen::MatrixXd points;   // #L by 2 or #L by 3
};

// Parses the JSON or .pts text; `source` names the file in errors. InvalidInput on malformed text, non-finite
// values, mixed dimensions, or a count other than 68 for scheme "ibug68".
Landmarks parse_landmarks_json(const std::string& text, const std::string& source);
Landmarks parse_landmarks_pts(const std::string& text, const std::string& source);

// Dispatches on the extension (.json, .pts).
Landmarks read_landmarks(const std::string& path);
// A photo's 68 landmarks in its pixels: read_landmarks, then InvalidInput unless they are 68 2D points within a
// border of one image size around the width x height image (farther ones are another image's or not pixels).
Landmarks read_image_landmarks(const std::string& path, int width, int height);
void write_landmarks(const std::string& path, const Landmarks& landmarks);

}  // namespace bareskin
