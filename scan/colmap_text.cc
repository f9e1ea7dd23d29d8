// COLMAP's TXT model (cameras.txt, images.txt, points3D.txt): read_colmap_text_model and parse_colmap_text_model
// (scan/colmap.h). Kept apart from running COLMAP so that the reader builds alone (tests/fuzz).
#include <Eigen/Geometry>
#include <fstream>
#include <map>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "scan/colmap.h"

namespace bareskin {
namespace {

// The lines of a TXT file that are neither empty nor comments.
std::vector<std::string> data_lines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);)
    if (!line.empty() && line[0] != '#') lines.push_back(line);
  return lines;
}

std::string read_model_file(const std::string& path) {
  if (!std::ifstream(path)) throw IoError(path, "cannot be read", "export the model as TXT (colmap model_converter --output_type TXT)");
  return read_file(path);
}

}  // namespace

ColmapModel read_colmap_text_model(const std::string& dir) {
  return parse_colmap_text_model(read_model_file(dir + "/cameras.txt"), read_model_file(dir + "/images.txt"),
                                 read_model_file(dir + "/points3D.txt"), dir);
}

ColmapModel parse_colmap_text_model(const std::string& cameras_txt, const std::string& images_txt,
                                    const std::string& points_txt, const std::string& dir) {
  struct Intrinsics {
    int width, height;
    double focal, cx, cy;
  };
  std::map<int, Intrinsics> cams;
  for (const std::string& line : data_lines(cameras_txt)) {
    std::istringstream s(line);
    int id, w, h;
    std::string model;
    std::vector<double> p;
    if (!(s >> id >> model >> w >> h)) throw InvalidInput(dir + "/cameras.txt", "has a malformed line", "re-export it");
    for (double x; s >> x;) p.push_back(x);
    Intrinsics in{w, h, 0, 0, 0};
    if ((model == "SIMPLE_PINHOLE" || model == "SIMPLE_RADIAL" || model == "RADIAL") && p.size() >= 3)
      in.focal = p[0], in.cx = p[1], in.cy = p[2];
    else if ((model == "PINHOLE" || model == "OPENCV") && p.size() >= 4)
      in.focal = (p[0] + p[1]) / 2, in.cx = p[2], in.cy = p[3];
    else
      throw InvalidInput(dir + "/cameras.txt", "camera model " + model + " is not supported",
                         "use SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL or OPENCV");
    cams[id] = in;
  }
  ColmapModel m;
  const auto images = data_lines(images_txt);
  // Two lines per image; the second (its 2D points) may be empty, and empty lines were dropped above, so parse the
  // image lines by their shape: 10 fields, the 9th an existing camera id.
  for (const std::string& line : images) {
    std::istringstream s(line);
    int id, cam;
    double qw, qx, qy, qz, tx, ty, tz;
    std::string name, extra;
    if (!(s >> id >> qw >> qx >> qy >> qz >> tx >> ty >> tz >> cam >> name) || (s >> extra) || !cams.count(cam)) continue;
    const Intrinsics& in = cams[cam];
    // COLMAP: x_c = R X + t, camera looking down +z, y down; ours looks down −z with y up: flip y and z.
    const Eigen::Matrix3d R = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
    const Eigen::Vector3d flip(1, -1, -1);
    ColmapImage im;
    im.name = name;
    im.camera.width = in.width, im.camera.height = in.height;
    im.camera.focal = in.focal, im.camera.cx = in.cx, im.camera.cy = in.cy;
    im.camera.R = flip.asDiagonal() * R;
    im.camera.t = flip.asDiagonal() * Eigen::Vector3d(tx, ty, tz);
    m.images.push_back(im);
  }
  const auto pts = data_lines(points_txt);
  m.points.resize(Eigen::Index(pts.size()), 3);
  for (size_t k = 0; k < pts.size(); ++k) {
    std::istringstream s(pts[k]);
    long id;
    double x, y, z, error = 0;
    int r, g, b;
    if (!(s >> id >> x >> y >> z)) throw InvalidInput(dir + "/points3D.txt", "has a malformed line", "re-export it");
    if (s >> r >> g >> b >> error) m.reprojection_px += error / double(pts.size());
    m.points.row(Eigen::Index(k)) << x, y, z;
  }
  if (m.images.empty()) throw InvalidInput(dir + "/images.txt", "holds no registered image", "check the model");
  return m;
}

}  // namespace bareskin
