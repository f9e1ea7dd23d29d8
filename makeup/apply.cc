#include "makeup/apply.h"

#include <chrono>
#include <filesystem>
#include <optional>

#include "core/error.h"
#include "core/files.h"
#include "core/png.h"
#include "core/assets.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/parallel.h"
#include "makeup/viewer.h"
#include "template/template_face.h"

namespace fs = std::filesystem;

namespace bareskin::looks {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

std::vector<Look> resolve_looks(const std::string& list) {
  std::vector<std::string> names;
  if (list == "all") {
    names = builtin_names();
  } else {
    size_t begin = 0;
    while (begin <= list.size()) {
      const size_t end = std::min(list.find(',', begin), list.size());
      if (end > begin) names.push_back(list.substr(begin, end - begin));
      begin = end + 1;
    }
  }
  if (names.empty()) throw InvalidInput("--look", "names no look", "give a built-in name, a .json file or all");
  std::vector<Look> looks;
  for (const auto& n : names) {
    looks.push_back(load_look(n));
    for (size_t i = 0; i + 1 < looks.size(); ++i)
      if (looks[i].name == looks.back().name)
        throw InvalidInput("--look", "names the look '" + looks.back().name + "' twice", "give each look once");
  }
  return looks;
}

// Vertices of an OBJ file: its "v " lines, counted without parsing the rest.
int64_t obj_vertex_count(const std::string& path) {
  const std::string text = read_file(path);
  int64_t n = 0;
  for (size_t at = 0; at < text.size(); at = text.find('\n', at) + 1) {
    if (text.compare(at, 2, "v ") == 0) ++n;
    if (text.find('\n', at) == std::string::npos) break;
  }
  return n;
}

// The template's landmark vertices on the avatar's own mesh (its shape, in mm, measures the regions). Only the
// template's landmarks.json is parsed (its vertex_ids) and its face.obj's vertices counted, to check that the avatar
// has the template's topology; a landmarks.json of 3D points is snapped through the whole template.
TemplateFace avatar_face(const avatar_folder::Folder& f, const std::string& template_dir) {
  const std::string dir = find_template_folder(template_dir);
  TemplateFace face;
  const auto doc = nlohmann::json::parse(read_file(dir + "/landmarks.json"), nullptr, false);
  int64_t vertices = 0;
  if (!doc.is_discarded() && doc.is_object() && doc.contains("vertex_ids")) {
    vertices = obj_vertex_count(dir + "/face.obj");
    if (vertices == f.mesh.V.rows())
      for (const auto& id : doc["vertex_ids"]) {
        if (!id.is_number_integer() || id.get<int64_t>() < 0 || id.get<int64_t>() >= vertices)
          throw InvalidInput(dir + "/landmarks.json", "vertex_ids holds an entry that is not a vertex", "");
        face.landmark_vertices.push_back(id.get<int>());
      }
  } else {
    face = read_template_folder(dir);
    vertices = face.mesh.V.rows();
  }
  if (vertices != f.mesh.V.rows())
    throw InvalidInput(f.dir + "/mesh.obj",
                       "has " + std::to_string(f.mesh.V.rows()) + " vertices, the template " + std::to_string(vertices),
                       "give --template the template folder the avatar's model was built on");
  face.mesh = f.mesh;
  return face;
}

// Whether the viewer's three.js is there (scripts/fetch_assets.sh); a warning when not.
bool viewer_assets() {
  try {
    find_data_dir(DataKind::Assets, "", "three/three.module.min.js");
    return true;
  } catch (const IoError& e) {
    spdlog::warn("viewer.html not written: {}", e.what());
    return false;
  }
}

void check_look(const makeup::MakeupLook& look, const Look& source, const std::string& regions) {
  if (look.layers.empty())
    throw InvalidInput("--region", "'" + regions + "' keeps no layer of the look '" + source.name + "'",
                       "pick regions the look paints (bareskin makeup show " + source.name + ")");
}

}  // namespace

void ApplyOptions::check() const {
  if (avatar.empty()) throw InvalidInput("avatar", "is missing", "give the avatar folder bareskin run wrote");
  if (output.empty()) throw InvalidInput("-o", "is missing", "give the output folder");
  if (preview_size < 16 || preview_size > 4096)
    throw InvalidInput("--preview-size", "must be in [16, 4096] pixels (got " + std::to_string(preview_size) + ")",
                       "e.g. --preview-size 512");
  if (max_layer_size < 16 || max_layer_size > 8192)
    throw InvalidInput("--max-layer-size", "must be in [16, 8192] texels (got " + std::to_string(max_layer_size) + ")",
                       "e.g. --max-layer-size 2048");
}

MadeUp apply_look(const avatar_folder::Folder& bare, const makeup::MakeupRegions& regions,
                  const makeup::MakeupLook& look) {
  MadeUp out{makeup::paint(regions, look, makeup::skin_tone(regions, bare.maps.diffuse)), bare};
  auto blend = [&](avatar_folder::MapSet& s) {
    makeup::apply_makeup(out.layer, s.diffuse, &s.roughness, &s.specular);
  };
  blend(out.folder.maps);
  if (out.folder.maps_hr) blend(*out.folder.maps_hr);
  return out;
}

Image before_after_sheet(const std::vector<Image>& before, const std::vector<Image>& after) {
  BS_CHECK(!before.empty() && before.size() == after.size(), "a before/after sheet needs pairs");
  const int t = before[0].width, gap = 4, cols = int(before.size());
  Image sheet(cols * t + (cols + 1) * gap, 2 * t + 3 * gap, 3, ColorSpace::sRGB, 1.0f);
  for (int row = 0; row < 2; ++row)
    for (int c = 0; c < cols; ++c) {
      const Image& tile = (row ? after : before)[size_t(c)];
      for (int y = 0; y < t; ++y)
        for (int x = 0; x < t; ++x)
          for (int k = 0; k < 3; ++k) sheet.at(gap + c * (t + gap) + x, gap + row * (t + gap) + y, k) = tile.at(x, y, k);
    }
  return sheet;
}

nlohmann::json apply_command(const ApplyOptions& o) {
  const auto t0 = Clock::now();
  // Everything checked first: the options, looks, regions, the folder, the template, the output path.
  o.check();
  const std::vector<Look> looks = resolve_looks(o.looks);
  const std::set<makeup::Region> keep = o.regions.empty() ? std::set<makeup::Region>{} : parse_region_list(o.regions);
  std::vector<makeup::MakeupLook> layers;
  for (const Look& l : looks) {
    layers.push_back(restrict_regions(l.layers, keep));
    check_look(layers.back(), l, o.regions);
  }
  check_output_apart(o.output, {o.avatar});
  const avatar_folder::Folder bare = avatar_folder::read(o.avatar);
  const TemplateFace face = avatar_face(bare, o.template_dir);
  const double t_read = since(t0);
  const int layer_size = std::min(bare.maps.diffuse.width, o.max_layer_size);
  std::set<makeup::Region> used;
  for (const auto& look : layers)
    for (const auto& l : look.layers) used.insert(l.region);
  const makeup::MakeupRegions regions = makeup::makeup_regions(face, layer_size, used);
  const double t_regions = since(t0) - t_read;

  nlohmann::json report = {{"avatar", o.avatar}, {"layer_size", layer_size},
                           {"map_size", bare.maps.diffuse.width},
                           {"map_size_hr", bare.maps_hr ? bare.maps_hr->diffuse.width : 0},
                           {"regions", o.regions.empty() ? "all" : o.regions}, {"looks", nlohmann::json::array()}};
  const auto lights = avatar_folder::preview_lights();
  const PbrScene scene = avatar_folder::preview_scene(bare, o.preview_size);  // the made-up copies share it
  const std::vector<Image> before = avatar_folder::previews(scene, bare.best(), lights);
  const bool viewer = viewer_assets();
  Image unwrap;
  if (viewer && fs::exists(bare.dir + "/unwrap.png")) unwrap = read_image(bare.dir + "/unwrap.png", ColorSpace::sRGB);
  std::optional<ShLight> photo;
  if (fs::exists(bare.dir + "/coefficients.json")) photo = avatar_folder::photo_light(bare.dir);
  std::vector<avatar_folder::MapSet> made_up;  // for the page of all looks
  AtomicDirectory out(o.output);
  for (size_t i = 0; i < looks.size(); ++i) {
    const auto t = Clock::now();
    const MadeUp m = apply_look(bare, regions, layers[i]);
    const double t_apply = since(t);
    const std::string dir = looks.size() == 1 ? out.path() : out.path() + "/" + looks[i].name;
    make_directories(dir);
    nlohmann::json look_json = looks[i].source;
    if (!keep.empty()) look_json["layers"] = nlohmann::json::array();
    for (size_t k = 0, j = 0; !keep.empty() && k < looks[i].layers.layers.size(); ++k)
      if (keep.count(looks[i].layers.layers[k].region)) look_json["layers"][j++] = looks[i].source["layers"][k];
    const std::vector<Image> after = avatar_folder::previews(scene, m.folder.best(), lights);
    std::string layer_png, sheet_png;  // encoded side by side
    parallel_for(0, 2, [&](int64_t b, int64_t e) {
      for (int64_t k = b; k < e; ++k)
        (k ? sheet_png : layer_png) =
            encode_png(k ? before_after_sheet(before, after) : makeup::layer_png_image(m.layer), 8);
    });
    const auto pngs = avatar_folder::write(dir, m.folder,
                                           {{"look.json", look_json.dump(2) + "\n"},
                                            {"makeup_layer.png", std::move(layer_png)},
                                            {"before_after.png", std::move(sheet_png)}},
                                           after);
    if (viewer) {  // this look first, then the bare maps and the photo's unwrap
      ViewerInputs in{&bare, {{looks[i].name, &m.folder.maps, nullptr}, {"bare", &bare.maps, nullptr}}, photo};
      in.variants[0].diffuse_png = pngs.at("diffuse"), in.variants[0].roughness_png = pngs.at("roughness");
      if (!unwrap.empty()) in.variants.push_back({"photo unwrap", nullptr, &unwrap});
      write_file_atomic(dir + "/viewer.html", viewer_html(in));
      if (looks.size() > 1) made_up.push_back(m.folder.maps);
    }
    report["looks"].push_back({{"name", looks[i].name}, {"layers", layers[i].layers.size()},
                               {"folder", looks.size() == 1 ? o.output : o.output + "/" + looks[i].name},
                               {"seconds_apply", t_apply}, {"seconds_total", since(t)}});
  }
  if (viewer && looks.size() > 1) {  // every look on one page
    ViewerInputs in{&bare, {{"bare", &bare.maps, nullptr}}, photo};
    for (size_t i = 0; i < looks.size(); ++i) in.variants.push_back({looks[i].name, &made_up[i], nullptr});
    if (!unwrap.empty()) in.variants.push_back({"photo unwrap", nullptr, &unwrap});
    write_file_atomic(out.path() + "/viewer.html", viewer_html(in));
  }
  report["seconds"] = {{"read", t_read}, {"regions", t_regions}, {"total", since(t0)}};
  write_file_atomic(out.path() + "/makeup_report.json", report.dump(2) + "\n");
  out.commit();
  return report;
}

}  // namespace bareskin::looks
