#include "makeup/avatar_folder.h"

#include <filesystem>
#include <functional>
#include <tuple>

#include "avatar/glb.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/mesh_cache.h"
#include "core/parallel.h"
#include "core/png.h"
#include "morphable/coefficients.h"
#include "texgen/texture_sample.h"

namespace fs = std::filesystem;

namespace bareskin::avatar_folder {
namespace {

constexpr uint64_t kPreviewLightSeed = 2022;  // as avatar/avatar.cc

// The first channel alone: roughness and specular are grey, which a file may hold as RGB.
Image first_channel(const Image& m) {
  Image g(m.width, m.height, 1, ColorSpace::Data);
  for (size_t i = 0; i < size_t(m.width) * m.height; ++i) g.pixels[i] = m.pixels[i * size_t(m.channels)];
  return g;
}

// A map as the renders use it: diffuse linear RGB, normal Data RGB, roughness and specular Data grey.
Image read_map(const std::string& path, const std::string& name, int channels) {
  if (!fs::exists(path))
    throw InvalidInput(path, "is missing: an avatar folder holds the four maps (diffuse, normal, roughness, specular)",
                       "give a folder written by bareskin run");
  Image m = read_image(path, name == "diffuse" ? ColorSpace::sRGB : ColorSpace::Data);
  if (m.channels < channels)
    throw InvalidInput(path, "has " + std::to_string(m.channels) + " channels, " + std::to_string(channels) + " needed",
                       "give the map bareskin run wrote");
  if (name == "diffuse") {
    if (m.color_space != ColorSpace::sRGB) m.color_space = ColorSpace::sRGB;
    return to_linear(m);
  }
  m.color_space = ColorSpace::Data;
  if (channels == 1 && m.channels > 1) return first_channel(m);
  return m;
}

// Decoding jobs for the four maps of a set: read_map into `s`.
void add_set_jobs(std::vector<std::function<void()>>& jobs, MapSet& s, const std::string& dir, const std::string& suffix) {
  Image* maps[4] = {&s.diffuse, &s.normal, &s.roughness, &s.specular};
  const int channels[4] = {3, 3, 1, 1};
  for (size_t i = 0; i < 4; ++i)
    jobs.push_back([=] { *maps[i] = read_map(dir + "/maps/" + kMapNames[i] + suffix + ".png", kMapNames[i], channels[i]); });
}

void check_set(const MapSet& s, const std::string& dir, const std::string& suffix) {
  for (const Image* m : {&s.normal, &s.roughness, &s.specular})
    if (m->width != s.diffuse.width || m->height != s.diffuse.height)
      throw InvalidInput(dir + "/maps", "the" + suffix + " maps differ in size", "give the maps bareskin run wrote");
}

}  // namespace

Folder read(const std::string& dir) {
  if (!fs::is_directory(dir)) throw InvalidInput(dir, "is not a folder", "give an avatar folder written by bareskin run");
  Folder f;
  f.dir = dir;
  const std::string mesh = dir + "/mesh.obj";
  if (!fs::exists(mesh)) throw InvalidInput(mesh, "is missing", "give an avatar folder written by bareskin run");
  int hr = 0;
  for (const char* m : kMapNames) hr += fs::exists(dir + "/maps/" + m + "_hr.png");
  if (hr > 0 && hr < 4)
    throw InvalidInput(dir + "/maps", "holds only " + std::to_string(hr) + " of the four _hr maps",
                       "give all four ×4 maps or none");
  if (hr == 4) f.maps_hr.emplace();
  // The mesh (through its binary copy beside it, written the first time: core/mesh_cache.h) and every map, decoded side
  // by side.
  std::vector<std::function<void()>> jobs = {[&] { f.mesh = read_mesh_cached(mesh); }};
  add_set_jobs(jobs, f.maps, dir, "");
  if (f.maps_hr) add_set_jobs(jobs, *f.maps_hr, dir, "_hr");
  parallel_for(0, int64_t(jobs.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) jobs[size_t(i)]();
  });
  if (!f.mesh.has_uv()) throw InvalidInput(mesh, "has no UVs", "give the mesh.obj bareskin run wrote");
  if (!f.mesh.has_normals()) f.mesh.N = vertex_normals(f.mesh.V, f.mesh.F);
  check_set(f.maps, dir, "");
  if (f.maps_hr) check_set(*f.maps_hr, dir, "_hr");
  return f;
}

std::vector<ShLight> preview_lights() {
  std::vector<ShLight> lights;
  for (int l = 0; l < 3; ++l) lights.push_back(texgen::sample_light(l, kPreviewLightSeed));
  return lights;
}

PbrScene preview_scene(const Folder& folder, int size) {
  return PbrScene(folder.mesh, orbit_camera(size, 0, 0, Eigen::Vector3d::Zero()), &folder.best().normal);
}

std::vector<Image> previews(const PbrScene& scene, const MapSet& maps, const std::vector<ShLight>& lights) {
  std::vector<Image> out;
  for (const ShLight& l : lights) {
    PbrLight light;
    light.sh = l;
    out.push_back(to_srgb(scene.shade(maps.view(), light).colour));
  }
  return out;
}

std::vector<Image> previews(const Folder& folder, const std::vector<ShLight>& lights, int size) {
  return previews(preview_scene(folder, size), folder.best(), lights);
}

std::map<std::string, std::string> write(const std::string& out, const Folder& f, const std::map<std::string, std::string>& extra,
           const std::vector<Image>& given_previews) {
  // Everything else of the source folder, as it is.
  const std::string src = f.dir;
  for (const auto& entry : fs::directory_iterator(src)) {
    const std::string name = entry.path().filename().string();
    if (name == "maps" || name == "avatar.glb" || name == kOutputMarker || name.rfind("preview_light", 0) == 0 ||
        extra.count(name))
      continue;
    fs::copy(entry.path(), fs::path(out) / name, fs::copy_options::recursive);
  }
  make_directories(out + "/maps");
  // Every map encoded once, in parallel (as bareskin run does).
  std::map<std::string, std::string> png;
  std::vector<std::pair<std::string, const Image*>> jobs;
  const Image diffuse = to_srgb(f.maps.diffuse), diffuse_hr = f.maps_hr ? to_srgb(f.maps_hr->diffuse) : Image();
  const Image specular_glb_map = texture::specular_texture(f.best().specular);
  for (const auto& [set, sfx, d] : {std::tuple{&f.maps, std::string(), &diffuse},
                                    std::tuple{f.maps_hr ? &*f.maps_hr : nullptr, std::string("_hr"), &diffuse_hr}}) {
    if (!set) continue;
    jobs.insert(jobs.end(), {{"diffuse" + sfx, d}, {"normal" + sfx, &set->normal}, {"roughness" + sfx, &set->roughness},
                             {"specular" + sfx, &set->specular}});
  }
  jobs.push_back({"glb_specular", &specular_glb_map});
  for (const auto& j : jobs) png[j.first];  // the map's nodes exist before the threads fill them
  parallel_for(0, int64_t(jobs.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) png.at(jobs[size_t(i)].first) = encode_png(*jobs[size_t(i)].second, 8);
  });
  const std::string specular_glb = png.at("glb_specular");
  png.erase("glb_specular");
  for (const auto& [name, bytes] : png) write_file_atomic(out + "/maps/" + name + ".png", bytes);
  const std::string sfx = f.maps_hr ? "_hr" : "";
  texture::write_glb(out + "/avatar.glb", f.mesh,
                     texture::PbrPngs{png.at("diffuse" + sfx), png.at("normal" + sfx), png.at("roughness" + sfx), specular_glb});
  const auto shots = given_previews.empty() ? previews(f, preview_lights(), 512) : given_previews;
  parallel_for(0, int64_t(shots.size()), [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) write_image(out + "/preview_light" + std::to_string(i + 1) + ".png", shots[size_t(i)]);
  });
  for (const auto& [name, bytes] : extra) {
    make_directories(fs::path(out + "/" + name).parent_path().string());
    write_file_atomic(out + "/" + name, bytes);
  }
  return png;
}

ShLight photo_light(const std::string& dir) {
  const std::string path = dir + "/coefficients.json";
  if (!fs::exists(path)) throw InvalidInput(path, "is missing", "give an avatar folder written by bareskin run");
  const Coefficients c = read_coefficients(path);
  if (!c.gamma) throw InvalidInput(path, "holds no fitted light (gamma)", "give --light, --env or --direction");
  return *c.gamma;
}

}  // namespace bareskin::avatar_folder
