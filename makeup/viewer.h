// viewer.html: an avatar in the browser, offline. One self-contained page (opens by double-click from file://, no
// server, no network): three.js (assets/three, pinned in scripts/assets.lock) and the GLB inlined, the GLB made from
// the 1× maps; a key light to turn (azimuth, elevation, intensity, ambient) with the photo's fitted light as a preset;
// a switch between the bare maps, each made-up look and the photo's unwrap. The page's state can be set from its URL
// hash (#variant=red_lips&az=40&el=20&i=1&amb=0.3&yaw=0, &preset=photo, &capture: the canvas as a PNG data URL in
// #capture) and it reports in #status ("ready" or the errors), which the browser test reads. docs/viewer.md.
#pragma once
#include <optional>
#include <string>
#include <vector>

#include "makeup/avatar_folder.h"

namespace bareskin::looks {

struct ViewerVariant {
  ViewerVariant(std::string name, const avatar_folder::MapSet* maps, const Image* diffuse_only)
      : name(std::move(name)), maps(maps), diffuse_only(diffuse_only) {}
  std::string name;                 // "bare", a look's name, "photo unwrap"
  const avatar_folder::MapSet* maps = nullptr;  // diffuse, roughness, specular used (the normal map stays the bare one)
  const Image* diffuse_only = nullptr;          // or a diffuse alone (sRGB or linear), e.g. the photo's unwrap
  // `maps`' diffuse (sRGB) and roughness as encode_png(·, 8) wrote them, where the caller has them (the page then
  // holds these bytes); empty: encoded here.
  std::string diffuse_png, roughness_png;
};

struct ViewerInputs {
  const avatar_folder::Folder* avatar = nullptr;  // mesh + bare maps (the 1× set)
  std::vector<ViewerVariant> variants;           // the first is shown first
  std::optional<ShLight> photo_light;            // the preset, when the folder has coefficients.json
};

// The page. IoError naming the assets folder when three.js is not there (scripts/fetch_assets.sh fetches it).
std::string viewer_html(const ViewerInputs& inputs);

// The variants an avatar folder offers on its own: its bare maps and, where it has unwrap.png, the photo's unwrap;
// plus the made-up folders given (each one's look.json names it). `keep` holds the folders read.
ViewerInputs folder_viewer(const avatar_folder::Folder& bare, const std::vector<avatar_folder::Folder>& looks,
                           std::vector<std::string>& look_names, Image& unwrap);

// `bareskin viewer AVATAR [--look DIR...] [-o FILE]`: writes the page (default AVATAR/viewer.html) atomically.
void viewer_command(const std::string& avatar, const std::vector<std::string>& look_dirs, const std::string& output);

}  // namespace bareskin::looks
