// Makeup looks as small JSON files a user edits (docs/makeup.md), compiled to texgen's layer model
// (texgen/makeup.h: regions in mm from the landmarks, palette colours, opacity, feather, finish). Built-in looks are
// the same JSON, written out here, so they go through the parser a user's file does.
#pragma once
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "texgen/makeup.h"

namespace bareskin::looks {

struct Look {
  std::string name, description;
  makeup::MakeupLook layers;  // style is Natural unless the file says otherwise (it only labels)
  nlohmann::json source;      // the JSON it came from
};

// The built-in looks' names, in `makeup list` order.
std::vector<std::string> builtin_names();
// A built-in look by name (InvalidInput naming `flag` and listing the names for another), or a look file when
// `name_or_file` ends in .json (InvalidInput naming the file and the offending key for a bad look, IoError when it
// cannot be read).
Look load_look(const std::string& name_or_file, const std::string& flag = "--look");
// Parses a look's JSON; `source` names it in errors ("file.json: layers[2].opacity is 1.4; ...").
Look parse_look(const nlohmann::json& j, const std::string& source);

// --region: a comma-separated list of region groups (lips, eyes, brows, cheeks, contour, base, paint) or of
// texgen's region names (lids, lash_line, ...); InvalidInput naming the flag for an unknown one.
std::set<makeup::Region> parse_region_list(const std::string& list, const std::string& flag = "--region");
// The groups and the regions each holds, for docs and `makeup list`.
const std::vector<std::pair<std::string, std::vector<makeup::Region>>>& region_groups();
// The look's layers on the given regions only (all of them when `keep` is empty).
makeup::MakeupLook restrict_regions(const makeup::MakeupLook& look, const std::set<makeup::Region>& keep);

}  // namespace bareskin::looks
