#include "makeup/relight.h"

#include <filesystem>
#include <nlohmann/json.hpp>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "makeup/avatar_folder.h"
#include "render/sh.h"

namespace fs = std::filesystem;

namespace bareskin::looks {
namespace {

std::vector<double> numbers(const std::string& text, size_t count, const std::string& flag, const std::string& hint) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw InvalidInput(flag, "'" + text + "' is not " + std::to_string(count) + " numbers", hint);
    }
  }
  if (v.size() != count || !Eigen::Map<Eigen::VectorXd>(v.data(), Eigen::Index(v.size())).allFinite())
    throw InvalidInput(flag, "'" + text + "' is not " + std::to_string(count) + " numbers", hint);
  return v;
}

// Box-averages a large environment down to at most 512 wide before the SH projection (same integral, less time).
Image shrink_env(const Image& env) {
  int f = 1;
  while (env.width / f > 512 && env.width % (2 * f) == 0 && env.height % (2 * f) == 0) f *= 2;
  if (f == 1) return env;
  Image s(env.width / f, env.height / f, 3, ColorSpace::Linear);
  for (int y = 0; y < s.height; ++y)
    for (int x = 0; x < s.width; ++x)
      for (int k = 0; k < 3; ++k) {
        double sum = 0;
        for (int j = 0; j < f; ++j)
          for (int i = 0; i < f; ++i) sum += env.at(x * f + i, y * f + j, k);
        s.at(x, y, k) = float(sum / (f * f));
      }
  return s;
}

ShLight env_light(const std::string& path) {
  if (!fs::exists(path)) throw InvalidInput(path, "does not exist", "give an equirectangular HDR (.exr, .hdr)");
  Image env;
  try {
    env = read_image(path, ColorSpace::Linear);
  } catch (const Error& e) {
    throw InvalidInput(path, "is not a readable image", "give an equirectangular HDR (.exr, .hdr)");
  }
  if (env.color_space == ColorSpace::sRGB) env = to_linear(env);
  try {
    return sh_from_environment(shrink_env(env));
  } catch (const InvalidInput& e) {
    throw InvalidInput(path, "is not an equirectangular RGB map of radiance ≥ 0 (" + std::to_string(env.width) + "×" +
                                 std::to_string(env.height) + ", " + std::to_string(env.channels) + " channels)",
                       "give a 2:1 latitude-longitude HDR");
  }
}

// --direction as a vector (not normalised) and --view as yaw, pitch: InvalidInput naming the flag.
Eigen::Vector3d key_direction(const std::string& text) {
  const auto d = numbers(text, 3, "--direction", "give x,y,z towards the light, e.g. 0.4,0.5,1");
  const Eigen::Vector3d dir(d[0], d[1], d[2]);
  if (dir.norm() < 1e-9) throw InvalidInput("--direction", "is the zero vector", "give x,y,z towards the light");
  return dir;
}
std::vector<double> view_angles(const std::string& text) {
  return numbers(text, 2, "--view", "give yaw,pitch in degrees, e.g. 30,10");
}

}  // namespace

void RelightOptions::check() const {
  const int given = int(!light.empty()) + int(!env.empty()) + int(!direction.empty());
  if (given > 1) throw InvalidInput("--light/--env/--direction", "more than one light given", "give one of them");
  if (!direction.empty()) key_direction(direction);
  if (!(intensity >= 0) || !(ambient >= 0))
    throw InvalidInput("--intensity/--ambient", "must be ≥ 0", "give a non-negative light");
  view_angles(view);
  if (size < 16 || size > 8192) throw InvalidInput("--size", "must be in [16, 8192]", "");
  if (export_width < 4 || export_width > 4096 || export_width % 2)
    throw InvalidInput("--export-width", "must be even and in [4, 4096]", "");
}

PbrLight chosen_light(const RelightOptions& o) {
  o.check();
  PbrLight light;
  if (!o.light.empty()) {
    if (!fs::exists(o.light)) throw InvalidInput(o.light, "does not exist", "give a JSON list of 27 SH coefficients");
    light.sh = read_sh_lighting(o.light);
  } else if (!o.env.empty()) {
    light.sh = env_light(o.env);
  } else if (!o.direction.empty()) {
    const Eigen::Vector3d dir = key_direction(o.direction);
    light.sh = sh_from_direction(dir, Eigen::Vector3d::Constant(o.intensity));
    for (int c = 0; c < 3; ++c) light.sh[size_t(9 * c)] += o.ambient / sh_scales().k0;
    light.key = {dir.normalized(), Eigen::Vector3d::Constant(o.intensity)};
  } else {
    light.sh = avatar_folder::photo_light(o.avatar);
  }
  return light;
}

Frame relight(const RelightOptions& o) {
  const PbrLight light = chosen_light(o);  // checks the options
  const auto yp = view_angles(o.view);
  const avatar_folder::Folder f = avatar_folder::read(o.avatar);
  return render_pbr(f.mesh, orbit_camera(o.size, yp[0], yp[1], Eigen::Vector3d::Zero()), f.best().view(), light);
}

void relight_command(const RelightOptions& o) {
  o.check();
  if (o.output.empty() && o.export_light.empty()) throw InvalidInput("-o", "is missing", "give -o image.png and/or --export-light DIR");
  if (!o.export_light.empty()) {
    const ShLight photo = avatar_folder::photo_light(o.avatar);
    if (!o.output.empty()) check_output_file(o.output);
    const Frame frame = o.output.empty() ? Frame{} : relight(o);
    make_directories(o.export_light);
    write_light_files(o.export_light, photo, o.export_width);
    if (!o.output.empty()) write_image(o.output, lower_extension(o.output) == ".exr" ? frame.colour : to_srgb(frame.colour));
    return;
  }
  check_output_file(o.output);
  const Frame frame = relight(o);
  write_image(o.output, lower_extension(o.output) == ".exr" ? frame.colour : to_srgb(frame.colour));
}

}  // namespace bareskin::looks
