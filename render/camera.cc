#include "render/camera.h"

#include <Eigen/Geometry>

#include "core/error.h"

namespace bareskin {

Eigen::Vector3d Camera::project(const Eigen::Vector3d& world) const {
  const Eigen::Vector3d p = R * world + t;
  if (model == Model::WeakPerspective) return {cx + scale * p.x(), cy - scale * p.y(), -p.z()};
  const double depth = -p.z();
  return {cx + focal * p.x() / depth, cy - focal * p.y() / depth, depth};
}

Camera view_camera(const std::string& view, int size, const Eigen::Vector3d& target, double distance) {
  Camera c;
  c.width = c.height = size;
  c.focal = 1015.0 * size / 224.0;
  c.cx = c.cy = size / 2.0;
  double yaw;  // rotation of the world about +y that brings the viewing direction onto +z
  if (view == "front") {
    yaw = 0;
  } else if (view == "left") {
    yaw = -M_PI / 2;  // the face's left (+x) turns toward the camera
  } else if (view == "right") {
    yaw = M_PI / 2;
  } else {
    throw InvalidInput("", "unknown view '" + view + "'", "use front, left or right");
  }
  c.R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  c.t = -c.R * target - Eigen::Vector3d(0, 0, distance);
  return c;
}

}  // namespace bareskin
