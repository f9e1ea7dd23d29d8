#include "makeup/looks.h"

#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"
#include "core/files.h"

namespace bareskin::looks {
namespace {

using makeup::Region;

// The built-in looks: the products and palettes of texgen's natural / light / heavy / dramatic styles, with fixed
// shades instead of random draws, plus three single-area looks.
const std::vector<std::pair<std::string, const char*>>& builtins() {
  static const std::vector<std::pair<std::string, const char*>> table = {
      {"natural", R"({"name": "natural", "description": "everyday: sheer base, peach blush, taupe lids, rose lips",
 "layers": [
  {"product": "foundation", "region": "face", "skin_factor": [1.1, 1.06, 1.0], "opacity": 0.55, "feather_mm": 4, "finish": "matte"},
  {"product": "concealer", "region": "under_eye", "skin_factor": [1.22, 1.2, 1.08], "opacity": 0.4, "feather_mm": 5},
  {"product": "blush", "region": "cheeks", "shade": "peach", "opacity": 0.3, "feather_mm": 12},
  {"product": "eyeshadow", "region": "lids", "shade": "taupe", "opacity": 0.4, "feather_mm": 4},
  {"product": "brow", "region": "brows", "shade": "medium_brown", "opacity": 0.4, "feather_mm": 1.5, "finish": "matte"},
  {"product": "lipstick", "region": "lips", "shade": "rose", "opacity": 0.65, "feather_mm": 1}]})"},
      {"light", R"({"name": "light", "description": "barely there: light base, baby-pink blush, nude lips",
 "layers": [
  {"product": "foundation", "region": "face", "skin_factor": [1.08, 1.05, 1.0], "opacity": 0.45, "feather_mm": 4},
  {"product": "blush", "region": "cheeks", "shade": "baby_pink", "opacity": 0.2, "feather_mm": 14},
  {"product": "lipstick", "region": "lips", "shade": "nude", "opacity": 0.5, "feather_mm": 1}]})"},
      {"glam", R"({"name": "glam", "description": "evening: full base, contour, rose blush, bronze shimmer lids, winged liner, red lips with gloss",
 "layers": [
  {"product": "foundation", "region": "face", "skin_factor": [1.12, 1.07, 1.0], "opacity": 0.75, "feather_mm": 4, "finish": "matte"},
  {"product": "concealer", "region": "under_eye", "skin_factor": [1.25, 1.22, 1.1], "opacity": 0.55, "feather_mm": 5},
  {"product": "contour", "region": "cheekbones", "skin_factor": [0.62, 0.57, 0.55], "opacity": 0.4, "feather_mm": 12, "finish": "matte"},
  {"product": "contour", "region": "jaw", "skin_factor": [0.62, 0.57, 0.55], "opacity": 0.35, "feather_mm": 12, "finish": "matte"},
  {"product": "contour", "region": "nose_sides", "skin_factor": [0.62, 0.57, 0.55], "opacity": 0.25, "feather_mm": 5, "finish": "matte"},
  {"product": "blush", "region": "cheeks", "shade": "rose", "opacity": 0.45, "feather_mm": 12},
  {"product": "eyeshadow", "region": "lids", "shade": "bronze", "opacity": 0.7, "feather_mm": 3, "shimmer": 0.4},
  {"product": "eyeshadow", "region": "crease", "shade": "brown", "opacity": 0.5, "feather_mm": 5, "finish": "matte"},
  {"product": "eyeliner", "region": "lash_line", "shade": "black", "opacity": 0.95, "feather_mm": 0.4, "offset_mm": 0.3},
  {"product": "eyeliner", "region": "wing", "shade": "black", "opacity": 0.95, "feather_mm": 0.4},
  {"product": "brow", "region": "brows", "shade": "dark_brown", "opacity": 0.6, "feather_mm": 1.2, "finish": "matte"},
  {"product": "lipstick", "region": "lips", "shade": "red", "opacity": 0.9, "feather_mm": 0.8},
  {"product": "gloss", "region": "lip_centre", "palette": "lipstick", "shade": "pink_nude", "opacity": 0.2, "feather_mm": 3, "offset_mm": 1, "finish": "gloss"}]})"},
      {"dramatic", R"({"name": "dramatic", "description": "stage: heavy contour, charcoal smoky eyes, thick liner, oxblood lips",
 "layers": [
  {"product": "foundation", "region": "face", "skin_factor": [1.15, 1.08, 1.0], "opacity": 0.85, "feather_mm": 4, "finish": "matte"},
  {"product": "contour", "region": "cheekbones", "skin_factor": [0.58, 0.53, 0.52], "opacity": 0.55, "feather_mm": 10, "finish": "matte"},
  {"product": "contour", "region": "jaw", "skin_factor": [0.58, 0.53, 0.52], "opacity": 0.5, "feather_mm": 10, "finish": "matte"},
  {"product": "blush", "region": "cheeks", "shade": "berry", "opacity": 0.5, "feather_mm": 10},
  {"product": "eyeshadow", "region": "smoky", "shade": "charcoal", "opacity": 0.85, "feather_mm": 4, "offset_mm": 1},
  {"product": "eyeliner", "region": "lash_line", "shade": "black", "opacity": 1, "feather_mm": 0.5, "offset_mm": 0.8},
  {"product": "eyeliner", "region": "wing", "shade": "black", "opacity": 1, "feather_mm": 0.5, "offset_mm": 0.4},
  {"product": "brow", "region": "brows", "shade": "soft_black", "opacity": 0.75, "feather_mm": 1, "finish": "matte"},
  {"product": "lipstick", "region": "lips", "palette": "dramatic_lipstick", "shade": "oxblood", "opacity": 0.95, "feather_mm": 0.8, "finish": "matte"}]})"},
      {"red_lips", R"({"name": "red_lips", "description": "lipstick only: a satin red",
 "layers": [
  {"product": "lipstick", "region": "lips", "shade": "red", "opacity": 0.9, "feather_mm": 1}]})"},
      {"smoky_eyes", R"({"name": "smoky_eyes", "description": "eyes only: charcoal smoky shadow and black liner",
 "layers": [
  {"product": "eyeshadow", "region": "smoky", "shade": "charcoal", "opacity": 0.8, "feather_mm": 4, "offset_mm": 0.5},
  {"product": "eyeliner", "region": "lash_line", "shade": "black", "opacity": 0.95, "feather_mm": 0.5, "offset_mm": 0.5}]})"},
      {"blush", R"({"name": "blush", "description": "cheeks only: a coral blush",
 "layers": [
  {"product": "blush", "region": "cheeks", "shade": "coral", "opacity": 0.45, "feather_mm": 12}]})"},
  };
  return table;
}

const std::vector<std::string> kLookKeys = {"name", "description", "style", "layers"};
const std::vector<std::string> kLayerKeys = {"product", "region",   "shade",       "palette",
                                             "colour",  "skin_factor", "opacity", "feather_mm",
                                             "offset_mm", "finish", "shimmer",     "pattern",
                                             "pattern_period_mm", "pattern_angle_deg", "seed"};

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

struct LayerReader {
  const nlohmann::json& e;
  std::string source, at;  // "file.json", "layers[2]"

  [[noreturn]] void bad(const std::string& key, const std::string& what, const std::string& hint) const {
    throw InvalidInput(source, at + (key.empty() ? "" : "." + key) + " " + what, hint);
  }
  float number(const std::string& key, float fallback, float lo, float hi, bool required = false) const {
    if (!e.contains(key)) {
      if (required) bad(key, "is missing", "give a number in [" + fmt(lo) + ", " + fmt(hi) + "]");
      return fallback;
    }
    if (!e[key].is_number()) bad(key, "is not a number", "give a number in [" + fmt(lo) + ", " + fmt(hi) + "]");
    const double v = e[key].get<double>();
    if (!std::isfinite(v) || v < lo || v > hi) bad(key, "is " + fmt(v) + ", out of range", "give a number in [" + fmt(lo) + ", " + fmt(hi) + "]");
    return float(v);
  }
  std::string text(const std::string& key, const std::string& fallback, bool required = false) const {
    if (!e.contains(key)) {
      if (required) bad(key, "is missing", "see docs/makeup.md");
      return fallback;
    }
    if (!e[key].is_string()) bad(key, "is not a string", "see docs/makeup.md");
    return e[key].get<std::string>();
  }
  static std::string fmt(double v) {
    std::string s = std::to_string(v);
    s.erase(s.find_last_not_of('0') + 1);
    if (!s.empty() && s.back() == '.') s.pop_back();
    return s;
  }
};

template <typename E>
E parse_enum(const LayerReader& r, const std::string& key, const std::string& fallback,
             const std::vector<std::string>& names) {
  const std::string v = r.text(key, fallback);
  const auto it = std::find(names.begin(), names.end(), v);
  if (it == names.end()) r.bad(key, "is '" + v + "', unknown", "use one of " + joined(names));
  return E(it - names.begin());
}

Eigen::Vector3f hex_colour(const LayerReader& r) {
  const std::string h = r.text("colour", "");
  if (h.size() != 7 || h[0] != '#' || h.find_first_not_of("0123456789abcdefABCDEF", 1) != std::string::npos)
    r.bad("colour", "is '" + h + "', not a colour", "give sRGB hex as \"#RRGGBB\"");
  const unsigned v = unsigned(std::stoul(h.substr(1), nullptr, 16));
  return {srgb_to_linear(float((v >> 16) & 255) / 255), srgb_to_linear(float((v >> 8) & 255) / 255),
          srgb_to_linear(float(v & 255) / 255)};
}

makeup::LayerSpec parse_layer(const LayerReader& r, size_t index) {
  if (!r.e.is_object()) r.bad("", "is not an object", "give {\"product\": ..., \"region\": ..., ...}");
  for (const auto& [key, value] : r.e.items())
    if (std::find(kLayerKeys.begin(), kLayerKeys.end(), key) == kLayerKeys.end())
      r.bad(key, "is an unknown key", "use " + joined(kLayerKeys));
  makeup::LayerSpec l;
  l.product = r.text("product", "", true);
  const std::string region = r.text("region", "", true);
  std::vector<std::string> region_names;
  for (int i = 0; i < makeup::kRegionCount; ++i) region_names.push_back(makeup::to_string(Region(i)));
  l.region = parse_enum<Region>(r, "region", "", region_names);
  const int given = int(r.e.contains("shade")) + int(r.e.contains("colour")) + int(r.e.contains("skin_factor"));
  if (given != 1) r.bad("", "needs exactly one of shade, colour, skin_factor", "see docs/makeup.md");
  if (r.e.contains("shade")) {
    const std::string palette_name = r.text("palette", l.product);
    std::vector<makeup::Shade> shades;
    try {
      shades = makeup::palette(palette_name);
    } catch (const InvalidInput&) {
      r.bad("palette", "'" + palette_name + "' is no palette",
            "add \"palette\": lipstick, blush, eyeshadow, eyeliner, brow, paint, dramatic_lipstick or dramatic_eyeshadow");
    }
    l.shade = r.text("shade", "");
    const auto it = std::find_if(shades.begin(), shades.end(), [&](const auto& s) { return s.name == l.shade; });
    if (it == shades.end()) {
      std::vector<std::string> names;
      for (const auto& s : shades) names.push_back(s.name);
      r.bad("shade", "'" + l.shade + "' is not in the " + palette_name + " palette", "use one of " + joined(names));
    }
    l.colour = it->linear;
  } else if (r.e.contains("colour")) {
    l.colour = hex_colour(r);
    l.shade = r.text("colour", "");
  } else {
    const auto& f = r.e["skin_factor"];
    if (!f.is_array() || f.size() != 3 || !f[0].is_number() || !f[1].is_number() || !f[2].is_number())
      r.bad("skin_factor", "is not three numbers", "give [r, g, b] factors of the skin colour, e.g. [1.1, 1.05, 1]");
    for (int k = 0; k < 3; ++k) {
      l.colour[k] = f[size_t(k)].get<float>();
      if (!std::isfinite(l.colour[k]) || l.colour[k] < 0 || l.colour[k] > 3)
        r.bad("skin_factor", "holds a factor out of [0, 3]", "give factors of the skin colour in [0, 3]");
    }
    l.mode = makeup::ColourMode::SkinRelative;
    l.shade = "skin_factor";
  }
  l.opacity = r.number("opacity", 0, 0, 1, true);
  l.feather_mm = r.number("feather_mm", 2, 0.05f, 24);
  l.offset_mm = r.number("offset_mm", 0, -6, 12);
  if (l.offset_mm + 0.5f * l.feather_mm > float(makeup::kMaxReachMm))
    r.bad("offset_mm", "plus half of feather_mm reaches beyond " + LayerReader::fmt(makeup::kMaxReachMm) + " mm",
          "make offset_mm + feather_mm / 2 at most " + LayerReader::fmt(makeup::kMaxReachMm));
  l.finish = parse_enum<makeup::Finish>(r, "finish", "satin", {"matte", "satin", "gloss"});
  l.shimmer = r.number("shimmer", 0, 0, 1);
  l.pattern = parse_enum<makeup::Pattern>(r, "pattern", "solid", {"solid", "stripes", "dots", "zigzag"});
  l.pattern_period_mm = r.number("pattern_period_mm", 6, 0.5f, 50);
  l.pattern_angle = r.number("pattern_angle_deg", 0, -360, 360) * float(M_PI / 180);
  if (r.e.contains("seed") && !r.e["seed"].is_number_unsigned()) r.bad("seed", "is not a whole number ≥ 0", "");
  l.seed = r.e.value("seed", uint64_t(1000 + index));
  return l;
}

}  // namespace

std::vector<std::string> builtin_names() {
  std::vector<std::string> names;
  for (const auto& [name, text] : builtins()) names.push_back(name);
  return names;
}

Look parse_look(const nlohmann::json& j, const std::string& source) {
  if (!j.is_object()) throw InvalidInput(source, "is not a JSON object", "see docs/makeup.md for a look's keys");
  for (const auto& [key, value] : j.items())
    if (std::find(kLookKeys.begin(), kLookKeys.end(), key) == kLookKeys.end())
      throw InvalidInput(source, "'" + key + "' is an unknown key", "use " + joined(kLookKeys));
  Look look;
  look.source = j;
  if (!j.contains("name") || !j["name"].is_string() || j["name"].get<std::string>().empty() ||
      j["name"].get<std::string>().find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_-") != std::string::npos)
    throw InvalidInput(source, "name is missing or not made of a-z, 0-9, _ and -", "give \"name\": \"my_look\"");
  look.name = j["name"].get<std::string>();
  look.description = j.value("description", "");
  look.layers.style = makeup::parse_style(j.value("style", "natural"), source + ": style");
  if (!j.contains("layers") || !j["layers"].is_array() || j["layers"].empty())
    throw InvalidInput(source, "layers is missing or empty", "give a list of layers (docs/makeup.md)");
  for (size_t i = 0; i < j["layers"].size(); ++i)
    look.layers.layers.push_back(
        parse_layer(LayerReader{j["layers"][i], source, "layers[" + std::to_string(i) + "]"}, i));
  return look;
}

Look load_look(const std::string& name, const std::string& flag) {
  if (lower_extension(name) == ".json") {
    const auto j = nlohmann::json::parse(read_file(name), nullptr, false);
    if (j.is_discarded()) throw InvalidInput(name, "is not valid JSON", "check the file's syntax (docs/makeup.md)");
    return parse_look(j, name);
  }
  for (const auto& [n, text] : builtins())
    if (n == name) return parse_look(nlohmann::json::parse(text), "built-in look " + n);
  throw InvalidInput(flag, "'" + name + "' is no built-in look and no .json file",
                     "use one of " + joined(builtin_names()) + ", or a look file ending in .json");
}

const std::vector<std::pair<std::string, std::vector<Region>>>& region_groups() {
  static const std::vector<std::pair<std::string, std::vector<Region>>> groups = {
      {"base", {Region::Face, Region::UnderEye}},
      {"contour", {Region::Cheekbones, Region::Jaw, Region::NoseSides}},
      {"cheeks", {Region::Cheeks}},
      {"eyes", {Region::Lids, Region::Crease, Region::Smoky, Region::LashLine, Region::Wing}},
      {"brows", {Region::Brows}},
      {"lips", {Region::Lips, Region::LipCentre}},
      {"paint", {Region::EyePaint, Region::CheekPaint}},
  };
  return groups;
}

std::set<Region> parse_region_list(const std::string& list, const std::string& flag) {
  std::set<Region> out;
  size_t begin = 0;
  while (begin <= list.size()) {
    const size_t end = std::min(list.find(',', begin), list.size());
    const std::string name = list.substr(begin, end - begin);
    begin = end + 1;
    if (name.empty()) continue;
    bool found = false;
    for (const auto& [group, regions] : region_groups())
      if (group == name) {
        out.insert(regions.begin(), regions.end());
        found = true;
      }
    for (int i = 0; i < makeup::kRegionCount && !found; ++i)
      if (name == makeup::to_string(Region(i))) {
        out.insert(Region(i));
        found = true;
      }
    if (!found) {
      std::vector<std::string> groups;
      for (const auto& g : region_groups()) groups.push_back(g.first);
      throw InvalidInput(flag, "'" + name + "' is an unknown region",
                         "use " + joined(groups) + " or a region name of docs/makeup.md");
    }
  }
  if (out.empty()) throw InvalidInput(flag, "names no region", "e.g. --region lips,eyes");
  return out;
}

makeup::MakeupLook restrict_regions(const makeup::MakeupLook& look, const std::set<Region>& keep) {
  if (keep.empty()) return look;
  makeup::MakeupLook out = look;
  out.layers.clear();
  for (const auto& l : look.layers)
    if (keep.count(l.region)) out.layers.push_back(l);
  return out;
}

}  // namespace bareskin::looks
