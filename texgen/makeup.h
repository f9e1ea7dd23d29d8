// Makeup as layers in the template UV (docs/datasets.md). A look is a stack of cosmetic layers (foundation, concealer,
// contour, blush, eyeshadow, eyeliner, brow fill, lipstick, gloss, painted patterns), each a colour, an opacity, a
// feather, a finish and an optional shimmer over a region of the face. Regions are signed-distance fields in mm built
// once per template from its 68 iBUG landmark vertices and UV coverage, so a layer's feather and offset are chosen per
// look. Painting a look gives one summed RGBA layer (the "over" composite of its layers, linear colour) plus finish
// deltas (roughness, specular); applying it to a subject's UV maps is
//   albedo = bare * (1 - a) + colour * a, layer by layer, in linear light,
// which the summed layer reproduces exactly (bare * (1 - A) + premultiplied colour).
#pragma once
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "core/image.h"
#include "template/template_face.h"

namespace bareskin::makeup {

// ---- styles ---------------------------------------------------------------------------------------------------------

enum class MakeupStyle { None, Light, Natural, Heavy, Dramatic };
constexpr int kStyleCount = 5;
const char* to_string(MakeupStyle style);
// InvalidInput naming `flag` for an unknown name.
MakeupStyle parse_style(const std::string& name, const std::string& flag = "--styles");
// A comma-separated list ("light,natural") or "all". Duplicates are dropped, order is kept; InvalidInput naming `flag`
// for an unknown name or an empty list.
std::vector<MakeupStyle> parse_styles(const std::string& list, const std::string& flag = "--styles");
// `styles` less `exclude` (--styles minus --exclude-styles); InvalidInput when nothing is left.
std::vector<MakeupStyle> select_styles(const std::vector<MakeupStyle>& styles, const std::vector<MakeupStyle>& exclude);
// One style drawn uniformly from `allowed` (non-empty) with the seeded generator; the same seed gives the same draw on
// every platform (no std:: distributions).
MakeupStyle sample_style(const std::vector<MakeupStyle>& allowed, std::mt19937_64& rng);

// ---- regions --------------------------------------------------------------------------------------------------------

enum class Region {
  Face,        // foundation: the UV-covered face less eyes, brows, lips and nostrils
  UnderEye,    // concealer: crescents under the lower lids
  Cheeks,      // blush: ellipses on the apples of the cheeks
  Cheekbones,  // contour: bands under the cheekbones, ear towards the mouth corner
  Jaw,         // contour: a band along the jaw line
  NoseSides,   // contour: two lines down the sides of the nose bridge
  Lips,        // lipstick: inside the outer lip contour (iBUG 48-59), smoothed
  LipCentre,   // gloss: the middle of the lower and upper lip
  Lids,        // eyeshadow: the mobile lid, lash line to about 45% of the way to the brow
  Crease,      // eyeshadow: a band in the socket between lid and brow bone
  Smoky,       // eyeshadow: lid + crease + the outer corner + a smudge under the lower lash line
  LashLine,    // eyeliner: a thin band along the upper lash line
  Wing,        // eyeliner: a tapered flick from the outer corner up and out
  Brows,       // brow fill: the brows, from the landmark polylines
  EyePaint,    // painted patterns (dramatic): a large area around the eyes, brow to cheekbone
  CheekPaint,  // painted patterns (dramatic): the cheeks and temples
};
constexpr int kRegionCount = 16;
const char* to_string(Region region);
Region parse_region(const std::string& name);  // InvalidInput for an unknown name

// Per region the signed distance to its boundary in mm (negative inside) on a uv_size² texel grid of the template UV
// (row 0 = v 1, texel centres at +0.5), plus the UV coverage of the face chart (1 inside) and the texel scale.
struct MakeupRegions {
  int uv_size = 0;
  double mm_per_texel = 0;  // sqrt(3D area / UV area) / uv_size
  Image coverage;           // 1 channel, Data: 1 where the template's UV triangles cover the texel
  Image exclusion;          // 1 channel, Data: eyes (open lid area), 1 inside, feathered 0.3 mm; no layer paints there
  std::array<Image, kRegionCount> distance;  // 1 channel, Data, mm
  // Texel box [x0, x1) x [y0, y1) outside which region r's distance is > kMaxReachMm (skip when painting).
  std::array<std::array<int, 4>, kRegionCount> box{};
  const Image& operator[](Region r) const { return distance[size_t(r)]; }
};
constexpr double kMaxReachMm = 12;  // a layer's offset + feather/2 never exceeds this

// InvalidInput when the template lacks the 68 landmark vertices, UVs or is not seamless, or uv_size is not in
// [32, 8192]. `only`: the regions to build (Face always, for skin_tone; empty: all); the others are left empty with
// an empty box, so paint() skips them. The regions are built in parallel (core/parallel.h).
MakeupRegions makeup_regions(const TemplateFace& face, int uv_size, const std::set<Region>& only = {});

// Landmark UVs of a template as texel coordinates at uv_size (x right, y down): for tests and overlays.
std::vector<Eigen::Vector2d> landmark_texels(const TemplateFace& face, int uv_size);

// ---- looks ----------------------------------------------------------------------------------------------------------

enum class Finish { Matte, Satin, Gloss };
const char* to_string(Finish finish);
enum class Pattern { Solid, Stripes, Dots, Zigzag };
const char* to_string(Pattern pattern);

// How a layer's colour is given: absolutely (linear RGB), or relative to the subject's skin tone (foundation,
// concealer, contour: skin * colour per channel), which paint() resolves with the skin tone it is given.
enum class ColourMode { Absolute, SkinRelative };

struct LayerSpec {
  std::string product;  // "foundation", "concealer", "contour", "blush", "eyeshadow", "eyeliner", "brow", "lipstick",
                        // "gloss", "paint"
  std::string shade;    // palette entry name ("red", "smoky", "coral", ...)
  Region region = Region::Face;
  ColourMode mode = ColourMode::Absolute;
  Eigen::Vector3f colour = Eigen::Vector3f::Zero();  // linear RGB, or per-channel factor of the skin (SkinRelative)
  float opacity = 0;                                 // peak alpha, 0..1
  float feather_mm = 2;                              // width of the 0->1 ramp across the region boundary
  float offset_mm = 0;                               // grows (>0) or shrinks (<0) the region
  Finish finish = Finish::Satin;
  float shimmer = 0;  // 0..1: density/strength of sparkling flecks (brighter colour, higher specular)
  Pattern pattern = Pattern::Solid;
  float pattern_period_mm = 6;  // Stripes/Dots/Zigzag spacing
  float pattern_angle = 0;      // radians, in the UV plane
  uint64_t seed = 0;            // shimmer flecks
};

struct MakeupLook {
  MakeupStyle style = MakeupStyle::None;
  std::vector<LayerSpec> layers;  // painted in this order
};

// A look of `style` drawn from the palettes (none: no layers). Deterministic per generator state.
MakeupLook sample_look(MakeupStyle style, std::mt19937_64& rng);

nlohmann::json to_json(const MakeupLook& look);
MakeupLook look_from_json(const nlohmann::json& j);  // InvalidInput for a malformed look

// Palettes (sRGB hex names as real cosmetics come) by product: "lipstick", "blush", "eyeshadow", "eyeliner", "brow",
// "paint", "dramatic_lipstick", "dramatic_eyeshadow"; each entry a (name, linear RGB) pair. For docs and tests.
struct Shade {
  std::string name;
  Eigen::Vector3f linear;
};
const std::vector<Shade>& palette(const std::string& product);

// ---- painting and applying ------------------------------------------------------------------------------------------

// Finish deltas added per layer, scaled by its alpha: matte raises roughness and lowers specular, gloss the reverse.
struct FinishDelta {
  float roughness, specular;
};
FinishDelta finish_delta(Finish finish);

// The summed layer of a look in the template UV (uv_size² of the regions).
struct MakeupLayer {
  Image colour;  // 4 channels, Linear: straight (not premultiplied) colour in RGB, total alpha A in the 4th
  Image finish;  // 2 channels, Data: roughness delta, specular delta (each in [-1, 1])
  // premultiplied colour C = colour * A: albedo' = albedo * (1 - A) + C
};

// Paints a look. `skin` (linear RGB) resolves skin-relative colours: the subject's mean bare albedo over the face,
// e.g. skin_tone(regions, diffuse). Throws InvalidInput for a colour or opacity out of range.
MakeupLayer paint(const MakeupRegions& regions, const MakeupLook& look, const Eigen::Vector3f& skin);

// Mean linear albedo of `diffuse_linear` (any size, template UV) over Region::Face (distance < 0).
Eigen::Vector3f skin_tone(const MakeupRegions& regions, const Image& diffuse_linear);

// Applies a layer to a subject's maps in the template UV, in place: diffuse (linear RGB, 3+ channels), roughness and
// specular (1 channel, optional). Maps of another size than the layer sample it bilinearly. InvalidInput when the
// diffuse is not linear colour.
void apply_makeup(const MakeupLayer& layer, Image& diffuse_linear, Image* roughness, Image* specular);

// The layer as the shard members store it: layer.png RGBA (sRGB colour, linear alpha) and finish.png grey+alpha
// (grey = (127 + 127 * roughness delta) / 255, alpha the same of the specular delta: 127 is no change), 8-bit. And
// back.
Image layer_png_image(const MakeupLayer& layer);   // 4 channels, values in [0,1], sRGB-tagged
Image finish_png_image(const MakeupLayer& layer);  // 2 channels, Data
MakeupLayer layer_from_png_images(const Image& layer_png, const Image& finish_png);

// ---- measuring ------------------------------------------------------------------------------------------------------

// CIELAB (D65 white) of a linear sRGB colour, and the CIE76 colour difference ΔE*ab.
Eigen::Vector3f linear_rgb_to_lab(const Eigen::Vector3f& rgb);
float delta_e(const Eigen::Vector3f& linear_a, const Eigen::Vector3f& linear_b);
// Mean ΔE between two linear albedo maps of the regions' size over the texels inside `region` (distance < 0, covered,
// not excluded); -1 when the region has no such texel.
double mean_delta_e(const MakeupRegions& regions, Region region, const Image& before_linear, const Image& after_linear);

}  // namespace bareskin::makeup
