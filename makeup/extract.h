// A makeup look read off a made-up face: the paper's "3D makeup avatar creation". Given the made-up face and its bare
// skin in the template UV (both albedo, linear RGB: `bareskin makeup extract` de-lights and unwraps the photo and the
// bare skin BareSkinNet recovers from it), each candidate layer (foundation, blush, lid shadow, brows, eyeliner,
// lipstick: texgen's layer model, docs/makeup.md) is fitted where its region is fully painted:
//   made = base (1 − a) + a C   (per texel, per channel; base: the bare skin under the layers fitted before it)
// a least-squares line of made against base with one slope 1 − a for the three channels and intercepts a C, then
// a raised until C lies in [0, 1]. A layer whose region changes by less than `min_delta_e` (mean ΔE*ab) is left
// out. The result is a look JSON that `makeup apply --look FILE.json` takes. docs/makeup.md, "Extracting a look".
#pragma once
#include <nlohmann/json.hpp>
#include <set>
#include <string>

#include "core/image.h"
#include "texgen/makeup.h"

namespace bareskin::looks {

struct ExtractOptions {
  std::string name = "extracted", description;
  double min_delta_e = 2.0;  // a candidate layer is kept when its region's mean ΔE*ab (made vs base) reaches this
  int min_texels = 12;       // ... over at least this many texels seen on both
  void check() const;        // InvalidInput naming the flag
};

// `made`, `bare`: linear RGB (3 channels) at the regions' size; `seen`: 1 channel, > 0.5 where both are known (null: all).
// InvalidInput when the sizes disagree. The regions must include the candidates' (extract_regions()).
nlohmann::json extract_look(const makeup::MakeupRegions& regions, const Image& made, const Image& bare,
                            const Image* seen, const ExtractOptions& options = {});

// The regions extract_look fits (for makeup_regions' `only`).
std::set<makeup::Region> extract_regions();

// `bareskin makeup extract --made UV.png --bare UV.png [--seen MASK.png] -o look.json`: the two unwraps in the
// template UV (sRGB PNGs of one size, e.g. `bareskin demakeup`'s uv.png without and with G), the regions built on the
// template (`template_dir`, else the default search) at their size, the look written atomically. InvalidInput naming
// the file for sizes that disagree and when no candidate region changes enough (no look found).
struct ExtractCommand {
  std::string made, bare, seen, template_dir, output;
  ExtractOptions options;
};
nlohmann::json extract_command(const ExtractCommand& command);

}  // namespace bareskin::looks
