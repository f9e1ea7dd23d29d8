// `bareskin makeup apply`: a makeup look on an avatar's bare maps, in the template UV, with texgen's layer model
// (texgen/makeup.h): the look painted once at the net's map size from regions in mm measured on the avatar's own
// mesh, then blended into the diffuse map (albedo' = albedo (1 − A) + C, linear light) and its finish into roughness
// and specular; the ×4 maps sample the same layer bilinearly. The output is a complete avatar folder (GLB, maps,
// previews) plus look.json, makeup_layer.png and before_after.png (renders before | after under three lights).
// Several looks (or `all`): one such folder per look under the output. docs/makeup.md.
#pragma once
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "makeup/avatar_folder.h"
#include "makeup/looks.h"
#include "texgen/makeup.h"

namespace bareskin::looks {

struct ApplyOptions {
  std::string avatar;           // the avatar folder (bareskin run's output)
  std::string output;           // the new avatar folder (one look) or a folder of them (several)
  std::string looks = "natural";  // a built-in name, a .json file, a comma-separated list of those, or "all"
  std::string regions;          // --region: only these (parse_region_list); empty: every layer
  std::string template_dir;     // --template: the template the avatar's model was built on (landmark vertex ids)
  int preview_size = 512;       // previews and the before/after tiles
  int max_layer_size = 2048;    // the look is painted at min(map size, this); larger maps sample it bilinearly
  void check() const;           // InvalidInput naming the flag
};

// The look on one avatar's maps: the painted layer and the made-up copy of the folder. `regions` must be built on
// the avatar's mesh at the layer size (makeup_regions).
struct MadeUp {
  makeup::MakeupLayer layer;
  avatar_folder::Folder folder;
};
MadeUp apply_look(const avatar_folder::Folder& bare, const makeup::MakeupRegions& regions,
                  const makeup::MakeupLook& look);

// The whole command: every input is checked before anything is written (InvalidInput naming the file, flag or key),
// then the output is written atomically. Returns the report (looks, sizes, seconds).
nlohmann::json apply_command(const ApplyOptions& options);

// A before/after contact sheet: row 1 the bare avatar, row 2 made up, one column per light (sRGB).
Image before_after_sheet(const std::vector<Image>& before, const std::vector<Image>& after);

}  // namespace bareskin::looks
