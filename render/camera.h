// Cameras for the renderer (docs/pipeline.md, units and axes: mm, +y up, +z toward the camera, which looks down −z).
// Pinhole: a world point x goes to the camera frame p = R x + t (p_z < 0 in front), then to pixels
// (cx + f p_x / −p_z, cy − f p_y / −p_z), row 0 at the top. Weak perspective: (cx + s p_x, cy − s p_y).
// Defaults follow Deep3DFaceRecon: focal 1015 px for a 224² image, principal point at the centre, the face 1 m away.
#pragma once
#include <Eigen/Core>
#include <string>

namespace bareskin {

struct Camera {
  enum class Model { Pinhole, WeakPerspective };
  Model model = Model::Pinhole;
  int width = 224, height = 224;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // world → camera
  Eigen::Vector3d t = Eigen::Vector3d(0, 0, -1000);
  double focal = 1015;  // pixels (pinhole)
  double scale = 1;     // pixels per mm (weak perspective)
  double cx = 112, cy = 112;

  // Pixel x, y and the depth along the view axis (−p_z, mm; > 0 in front of a pinhole camera).
  Eigen::Vector3d project(const Eigen::Vector3d& world) const;
};

// Deep3DFaceRecon's camera for a size² image, looking at `target` from `distance` mm along the view's axis:
// "front" (from +z), "left" (from the face's left, +x), "right" (from −x). InvalidInput for another name.
Camera view_camera(const std::string& view, int size, const Eigen::Vector3d& target, double distance = 1000);

}  // namespace bareskin
