// Makeup styles, palettes and the seeded look sampler; looks to and from JSON.
#include <algorithm>
#include <cmath>
#include <map>

#include "core/error.h"
#include "texgen/makeup.h"

namespace bareskin::makeup {
namespace {

const char* const kStyleNames[kStyleCount] = {"none", "light", "natural", "heavy", "dramatic"};
const char* const kRegionNames[kRegionCount] = {"face", "under_eye",  "cheeks",    "cheekbones", "jaw",   "nose_sides",
                                                "lips", "lip_centre", "lids",      "crease",     "smoky", "lash_line",
                                                "wing", "brows",      "eye_paint", "cheek_paint"};
const char* const kFinishNames[] = {"matte", "satin", "gloss"};
const char* const kPatternNames[] = {"solid", "stripes", "dots", "zigzag"};

// Platform-independent draws from the 64-bit generator (std:: distributions differ between standard libraries).
double uniform(std::mt19937_64& rng) { return double(rng() >> 11) * 0x1.0p-53; }
float range(std::mt19937_64& rng, double lo, double hi) { return float(lo + (hi - lo) * uniform(rng)); }
bool chance(std::mt19937_64& rng, double p) { return uniform(rng) < p; }
size_t index(std::mt19937_64& rng, size_t n) { return std::min(n - 1, size_t(uniform(rng) * double(n))); }

Eigen::Vector3f hex(uint32_t rgb) {
  return {srgb_to_linear(float((rgb >> 16) & 255) / 255.f), srgb_to_linear(float((rgb >> 8) & 255) / 255.f),
          srgb_to_linear(float(rgb & 255) / 255.f)};
}

struct PaletteTable {
  std::map<std::string, std::vector<Shade>> table;
  PaletteTable() {
    auto add = [&](const std::string& product, std::initializer_list<std::pair<const char*, uint32_t>> shades) {
      for (const auto& [name, rgb] : shades) table[product].push_back({name, hex(rgb)});
    };
    // Swatch colours of common cosmetics as worn (sRGB), from sheer nudes to deep berries.
    add("lipstick", {{"nude", 0xB9806E},
                     {"pink_nude", 0xC4847F},
                     {"rose", 0xB55A6A},
                     {"pink", 0xD0607E},
                     {"hot_pink", 0xCC2F6E},
                     {"coral", 0xDC5F55},
                     {"red", 0xB01E2A},
                     {"cherry", 0x98182E},
                     {"brick", 0x983A2C},
                     {"plum", 0x6A2444},
                     {"berry", 0x862246},
                     {"mauve", 0x9A6276},
                     {"brown", 0x7A4636},
                     {"chocolate", 0x5A3026}});
    add("blush", {{"baby_pink", 0xF0A0B0},
                  {"rose", 0xD87888},
                  {"coral", 0xEE8670},
                  {"peach", 0xF2A07A},
                  {"berry", 0xBE5670},
                  {"bronze", 0xBE7654}});
    add("eyeshadow", {{"champagne", 0xE2C6A4},
                      {"taupe", 0x8A7262},
                      {"brown", 0x684634},
                      {"bronze", 0xA46638},
                      {"gold", 0xC49C48},
                      {"charcoal", 0x383434},
                      {"black", 0x1E1C1C},
                      {"plum", 0x5C344E},
                      {"navy", 0x2C3858},
                      {"emerald", 0x2C684C},
                      {"rose_gold", 0xC48878},
                      {"mauve", 0x8E6878}});
    add("eyeliner", {{"black", 0x141414}, {"brown", 0x3C2A20}, {"navy", 0x1C284A}});
    add("brow", {{"dark_brown", 0x46342A}, {"medium_brown", 0x6A4E3A}, {"soft_black", 0x2C2422}, {"taupe", 0x786454}});
    add("dramatic_lipstick", {{"black", 0x1A181E},
                              {"blue", 0x2848B0},
                              {"green", 0x288848},
                              {"purple", 0x682896},
                              {"white", 0xE6DEE6},
                              {"orange", 0xF85A1E},
                              {"oxblood", 0x600A16},
                              {"teal", 0x18807C}});
    add("dramatic_eyeshadow", {{"electric_blue", 0x1E68E0},
                               {"neon_green", 0x48D048},
                               {"yellow", 0xF0D020},
                               {"hot_pink", 0xF0308A},
                               {"orange", 0xF07020},
                               {"red", 0xC81E28},
                               {"violet", 0x8A2AD0},
                               {"turquoise", 0x20C0C0},
                               {"white", 0xF0F0F0},
                               {"black", 0x141414}});
    add("paint", {{"white", 0xF4F4F4},
                  {"black", 0x121212},
                  {"red", 0xD01A1A},
                  {"blue", 0x1A4AD0},
                  {"gold", 0xD4A838},
                  {"green", 0x1AA04A},
                  {"silver", 0xC8C8D0},
                  {"purple", 0x7A1AB0}});
  }
};

const PaletteTable& palettes() {
  static const PaletteTable p;
  return p;
}

LayerSpec from_palette(std::mt19937_64& rng, const std::string& product, const std::string& palette_name,
                       Region region) {
  const std::vector<Shade>& shades = palette(palette_name);
  const Shade& s = shades[index(rng, shades.size())];
  LayerSpec l;
  l.product = product;
  l.shade = s.name;
  l.region = region;
  l.colour = s.linear;
  l.seed = rng();
  return l;
}

// Skin-relative shades: foundation a little lighter/darker, warmer/cooler than the skin; concealer lighter and peach;
// contour darker and a touch cool.
LayerSpec skin_layer(std::mt19937_64& rng, const std::string& product, Region region) {
  LayerSpec l;
  l.product = product;
  l.region = region;
  l.mode = ColourMode::SkinRelative;
  l.seed = rng();
  if (product == "foundation") {
    // Shade steps of real ranges: 6-18% lighter (more often) or darker than the skin, warmer or cooler.
    const float step = range(rng, 0.06, 0.18), light = chance(rng, 0.65) ? step : -step, warm = range(rng, -0.06, 0.06);
    l.colour = Eigen::Vector3f(1 + warm, 1, 1 - warm) * (1 + light);
    l.shade = light > 0 ? "lighter" : "deeper";
  } else if (product == "concealer") {
    const float light = range(rng, 1.15, 1.35);
    l.colour = Eigen::Vector3f(1.02f, 1.0f, 0.9f) * light;
    l.shade = "peach_light";
  } else {
    const float dark = range(rng, 0.55, 0.75);
    l.colour = Eigen::Vector3f(0.98f, 0.92f, 0.88f) * dark;
    l.shade = "cool_brown";
  }
  return l;
}

LayerSpec& tune(LayerSpec& l, float opacity, float feather, Finish finish, float offset = 0) {
  l.opacity = opacity;
  l.feather_mm = feather;
  l.finish = finish;
  l.offset_mm = offset;
  return l;
}

Finish any_finish(std::mt19937_64& rng) { return Finish(index(rng, 3)); }

void add_base(MakeupLook& look, std::mt19937_64& rng, double lo, double hi) {
  LayerSpec f = skin_layer(rng, "foundation", Region::Face);
  look.layers.push_back(
      tune(f, range(rng, lo, hi), range(rng, 2, 5), chance(rng, 0.6) ? Finish::Matte : Finish::Satin));
}

void add_lips(MakeupLook& look, std::mt19937_64& rng, const std::string& palette_name, double lo, double hi,
              double gloss) {
  LayerSpec l = from_palette(rng, "lipstick", palette_name, Region::Lips);
  look.layers.push_back(tune(l, range(rng, lo, hi), range(rng, 0.6, 1.4), any_finish(rng), range(rng, -0.3, 0.5)));
  if (chance(rng, gloss)) {
    LayerSpec g = from_palette(rng, "gloss", "lipstick", Region::LipCentre);
    g.colour = 0.5f * (g.colour + Eigen::Vector3f::Ones());  // clear with a tint
    g.shimmer = chance(rng, 0.3) ? range(rng, 0.2, 0.6) : 0;
    look.layers.push_back(tune(g, range(rng, 0.1, 0.25), range(rng, 2, 4), Finish::Gloss, range(rng, 0.5, 2)));
  }
}

MakeupLook sample_light(std::mt19937_64& rng) {
  MakeupLook look;
  add_base(look, rng, 0.45, 0.6);
  if (chance(rng, 0.5)) {
    LayerSpec b = from_palette(rng, "blush", "blush", Region::Cheeks);
    look.layers.push_back(tune(b, range(rng, 0.15, 0.3), range(rng, 10, 16), Finish::Satin));
  }
  if (chance(rng, 0.4)) {
    LayerSpec b = from_palette(rng, "brow", "brow", Region::Brows);
    look.layers.push_back(tune(b, range(rng, 0.2, 0.35), range(rng, 1, 2), Finish::Matte));
  }
  add_lips(look, rng, "lipstick", 0.45, 0.65, 0.3);
  return look;
}

MakeupLook sample_natural(std::mt19937_64& rng) {
  MakeupLook look;
  add_base(look, rng, 0.5, 0.7);
  if (chance(rng, 0.6)) {
    LayerSpec c = skin_layer(rng, "concealer", Region::UnderEye);
    look.layers.push_back(tune(c, range(rng, 0.3, 0.5), range(rng, 4, 7), Finish::Satin));
  }
  LayerSpec b = from_palette(rng, "blush", "blush", Region::Cheeks);
  look.layers.push_back(tune(b, range(rng, 0.25, 0.4), range(rng, 10, 16), Finish::Satin));
  LayerSpec e = from_palette(rng, "eyeshadow", "eyeshadow", Region::Lids);
  e.shimmer = chance(rng, 0.3) ? range(rng, 0.1, 0.4) : 0;
  look.layers.push_back(tune(e, range(rng, 0.3, 0.5), range(rng, 3, 5), Finish::Satin));
  if (chance(rng, 0.5)) {
    LayerSpec l = from_palette(rng, "eyeliner", "eyeliner", Region::LashLine);
    look.layers.push_back(tune(l, range(rng, 0.5, 0.8), range(rng, 0.4, 0.8), Finish::Satin));
  }
  LayerSpec w = from_palette(rng, "brow", "brow", Region::Brows);
  look.layers.push_back(tune(w, range(rng, 0.3, 0.5), range(rng, 1, 2), Finish::Matte));
  add_lips(look, rng, "lipstick", 0.55, 0.8, 0.3);
  return look;
}

void add_contour(MakeupLook& look, std::mt19937_64& rng, double lo, double hi) {
  for (Region r : {Region::Cheekbones, Region::Jaw, Region::NoseSides}) {
    LayerSpec c = skin_layer(rng, "contour", r);
    const bool nose = r == Region::NoseSides;  // a thin soft shade along the bridge, fainter than the cheek contour
    look.layers.push_back(tune(c, nose ? 0.6f * range(rng, lo, hi) : range(rng, lo, hi),
                               nose ? range(rng, 4, 6) : range(rng, 10, 14), Finish::Matte));
  }
}

MakeupLook sample_heavy(std::mt19937_64& rng) {
  MakeupLook look;
  add_base(look, rng, 0.65, 0.85);
  LayerSpec c = skin_layer(rng, "concealer", Region::UnderEye);
  look.layers.push_back(tune(c, range(rng, 0.45, 0.7), range(rng, 4, 7), Finish::Satin));
  add_contour(look, rng, 0.3, 0.5);
  LayerSpec b = from_palette(rng, "blush", "blush", Region::Cheeks);
  look.layers.push_back(tune(b, range(rng, 0.35, 0.55), range(rng, 10, 14), any_finish(rng)));
  LayerSpec lid = from_palette(rng, "eyeshadow", "eyeshadow", Region::Lids);
  lid.shimmer = chance(rng, 0.4) ? range(rng, 0.2, 0.7) : 0;
  look.layers.push_back(
      tune(lid, range(rng, 0.55, 0.8), range(rng, 2, 4), lid.shimmer > 0 ? Finish::Satin : Finish::Matte));
  LayerSpec crease = from_palette(rng, "eyeshadow", "eyeshadow", Region::Crease);
  look.layers.push_back(tune(crease, range(rng, 0.4, 0.65), range(rng, 4, 6), Finish::Matte));
  LayerSpec liner = from_palette(rng, "eyeliner", "eyeliner", Region::LashLine);
  look.layers.push_back(tune(liner, range(rng, 0.85, 1.0), range(rng, 0.3, 0.6), Finish::Satin, range(rng, 0, 0.5)));
  if (chance(rng, 0.6)) {
    LayerSpec wing = liner;
    wing.region = Region::Wing;
    look.layers.push_back(tune(wing, liner.opacity, range(rng, 0.3, 0.6), Finish::Satin));
  }
  LayerSpec w = from_palette(rng, "brow", "brow", Region::Brows);
  look.layers.push_back(tune(w, range(rng, 0.5, 0.7), range(rng, 0.8, 1.5), Finish::Matte));
  add_lips(look, rng, "lipstick", 0.75, 0.95, 0.4);
  return look;
}

MakeupLook sample_dramatic(std::mt19937_64& rng) {
  MakeupLook look;
  add_base(look, rng, 0.75, 0.95);
  add_contour(look, rng, 0.4, 0.65);
  LayerSpec b = from_palette(rng, "blush", chance(rng, 0.4) ? "dramatic_eyeshadow" : "blush", Region::Cheeks);
  look.layers.push_back(tune(b, range(rng, 0.4, 0.65), range(rng, 8, 12), any_finish(rng)));
  LayerSpec smoky =
      from_palette(rng, "eyeshadow", chance(rng, 0.6) ? "dramatic_eyeshadow" : "eyeshadow", Region::Smoky);
  smoky.shimmer = chance(rng, 0.4) ? range(rng, 0.3, 0.9) : 0;
  look.layers.push_back(tune(smoky, range(rng, 0.7, 0.95), range(rng, 3, 6), any_finish(rng), range(rng, 0, 2)));
  if (chance(rng, 0.5)) {
    LayerSpec lid = from_palette(rng, "eyeshadow", "dramatic_eyeshadow", Region::Lids);
    look.layers.push_back(tune(lid, range(rng, 0.6, 0.9), range(rng, 2, 3), any_finish(rng)));
  }
  LayerSpec liner =
      from_palette(rng, "eyeliner", chance(rng, 0.3) ? "dramatic_eyeshadow" : "eyeliner", Region::LashLine);
  look.layers.push_back(tune(liner, range(rng, 0.9, 1.0), range(rng, 0.3, 0.6), Finish::Satin, range(rng, 0.3, 1.2)));
  LayerSpec wing = liner;
  wing.region = Region::Wing;
  look.layers.push_back(tune(wing, liner.opacity, range(rng, 0.3, 0.6), Finish::Satin, range(rng, 0, 0.8)));
  LayerSpec w = from_palette(rng, "brow", "brow", Region::Brows);
  look.layers.push_back(tune(w, range(rng, 0.6, 0.85), range(rng, 0.6, 1.2), Finish::Matte, range(rng, 0, 0.6)));
  add_lips(look, rng, chance(rng, 0.6) ? "dramatic_lipstick" : "lipstick", 0.85, 1.0, 0.4);
  if (chance(rng, 0.6)) {  // painted pattern (LADN's extreme looks)
    LayerSpec p = from_palette(rng, "paint", "paint", chance(rng, 0.5) ? Region::EyePaint : Region::CheekPaint);
    p.pattern = Pattern(index(rng, 4));
    p.pattern_period_mm = range(rng, 3, 9);
    p.pattern_angle = range(rng, 0, M_PI);
    look.layers.push_back(tune(p, range(rng, 0.6, 0.9), range(rng, 2, 5), any_finish(rng)));
  }
  return look;
}

template <typename E, size_t N>
E parse_name(const char* const (&names)[N], const std::string& name, const std::string& what) {
  for (size_t i = 0; i < N; ++i)
    if (name == names[i]) return E(i);
  std::string all;
  for (size_t i = 0; i < N; ++i) all += (i ? ", " : "") + std::string(names[i]);
  throw InvalidInput(what, "unknown name '" + name + "'", "use one of " + all);
}

}  // namespace

const char* to_string(MakeupStyle style) { return kStyleNames[int(style)]; }
const char* to_string(Region region) { return kRegionNames[int(region)]; }
const char* to_string(Finish finish) { return kFinishNames[int(finish)]; }
const char* to_string(Pattern pattern) { return kPatternNames[int(pattern)]; }

MakeupStyle parse_style(const std::string& name, const std::string& flag) {
  return parse_name<MakeupStyle>(kStyleNames, name, flag);
}
Region parse_region(const std::string& name) { return parse_name<Region>(kRegionNames, name, "makeup region"); }

std::vector<MakeupStyle> parse_styles(const std::string& list, const std::string& flag) {
  std::vector<MakeupStyle> out;
  if (list.find_first_not_of(" ,") == std::string::npos) {
    throw InvalidInput(flag, "names no style", "give none, light, natural, heavy, dramatic (comma-separated) or all");
  }
  if (list == "all") {
    for (int i = 0; i < kStyleCount; ++i) out.push_back(MakeupStyle(i));
    return out;
  }
  size_t begin = 0;
  while (begin <= list.size()) {
    const size_t end = std::min(list.find(',', begin), list.size());
    std::string name = list.substr(begin, end - begin);
    name.erase(0, name.find_first_not_of(' '));
    name.erase(name.find_last_not_of(' ') + 1);
    const MakeupStyle s = parse_style(name, flag);
    if (std::find(out.begin(), out.end(), s) == out.end()) out.push_back(s);
    begin = end + 1;
  }
  return out;
}

std::vector<MakeupStyle> select_styles(const std::vector<MakeupStyle>& styles,
                                       const std::vector<MakeupStyle>& exclude) {
  std::vector<MakeupStyle> out;
  for (MakeupStyle s : styles)
    if (std::find(exclude.begin(), exclude.end(), s) == exclude.end()) out.push_back(s);
  if (out.empty()) {
    throw InvalidInput("--exclude-styles", "excludes every style --styles selects", "keep at least one style");
  }
  return out;
}

MakeupStyle sample_style(const std::vector<MakeupStyle>& allowed, std::mt19937_64& rng) {
  BS_CHECK(!allowed.empty(), "sample_style needs at least one style");
  return allowed[index(rng, allowed.size())];
}

const std::vector<Shade>& palette(const std::string& product) {
  const auto& table = palettes().table;
  const auto it = table.find(product);
  if (it == table.end()) throw InvalidInput("makeup palette", "no palette '" + product + "'", "see docs/datasets.md");
  return it->second;
}

MakeupLook sample_look(MakeupStyle style, std::mt19937_64& rng) {
  MakeupLook look;
  switch (style) {
    case MakeupStyle::None:
      break;
    case MakeupStyle::Light:
      look = sample_light(rng);
      break;
    case MakeupStyle::Natural:
      look = sample_natural(rng);
      break;
    case MakeupStyle::Heavy:
      look = sample_heavy(rng);
      break;
    case MakeupStyle::Dramatic:
      look = sample_dramatic(rng);
      break;
  }
  look.style = style;
  return look;
}

nlohmann::json to_json(const MakeupLook& look) {
  nlohmann::json layers = nlohmann::json::array();
  for (const LayerSpec& l : look.layers) {
    layers.push_back({{"product", l.product},
                      {"shade", l.shade},
                      {"region", to_string(l.region)},
                      {"colour_mode", l.mode == ColourMode::Absolute ? "linear_rgb" : "skin_factor"},
                      {"colour", {l.colour.x(), l.colour.y(), l.colour.z()}},
                      {"opacity", l.opacity},
                      {"feather_mm", l.feather_mm},
                      {"offset_mm", l.offset_mm},
                      {"finish", to_string(l.finish)},
                      {"shimmer", l.shimmer},
                      {"pattern", to_string(l.pattern)},
                      {"pattern_period_mm", l.pattern_period_mm},
                      {"pattern_angle", l.pattern_angle},
                      {"seed", l.seed}});
  }
  return {{"style", to_string(look.style)}, {"layers", layers}};
}

MakeupLook look_from_json(const nlohmann::json& j) {
  try {
    MakeupLook look;
    look.style = parse_style(j.at("style").get<std::string>(), "makeup look");
    for (const auto& e : j.at("layers")) {
      LayerSpec l;
      l.product = e.at("product").get<std::string>();
      l.shade = e.value("shade", "");
      l.region = parse_region(e.at("region").get<std::string>());
      const std::string mode = e.value("colour_mode", "linear_rgb");
      if (mode != "linear_rgb" && mode != "skin_factor") {
        throw InvalidInput("makeup look", "unknown colour_mode '" + mode + "'", "use linear_rgb or skin_factor");
      }
      l.mode = mode == "linear_rgb" ? ColourMode::Absolute : ColourMode::SkinRelative;
      const auto c = e.at("colour").get<std::vector<float>>();
      if (c.size() != 3) throw InvalidInput("makeup look", "a layer colour needs 3 values", "give [r, g, b]");
      l.colour = {c[0], c[1], c[2]};
      l.opacity = e.at("opacity").get<float>();
      l.feather_mm = e.value("feather_mm", 2.0f);
      l.offset_mm = e.value("offset_mm", 0.0f);
      l.finish = parse_name<Finish>(kFinishNames, e.value("finish", "satin"), "makeup finish");
      l.shimmer = e.value("shimmer", 0.0f);
      l.pattern = parse_name<Pattern>(kPatternNames, e.value("pattern", "solid"), "makeup pattern");
      l.pattern_period_mm = e.value("pattern_period_mm", 6.0f);
      l.pattern_angle = e.value("pattern_angle", 0.0f);
      l.seed = e.value("seed", uint64_t(0));
      look.layers.push_back(l);
    }
    return look;
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput("makeup look", std::string("malformed JSON: ") + e.what(), "write it with to_json");
  }
}

}  // namespace bareskin::makeup
