// bareskin viewer: an avatar folder's offline viewer.html (makeup/viewer.h): the GLB with its maps, a light to turn,
// the bare maps, the made-up folders given and the photo's unwrap.
#include "apps/cli.h"
#include "makeup/viewer.h"

namespace bareskin::cli {

std::function<void()> setup_viewer_command(CLI::App& app, const Globals& globals) {
  auto avatar = std::make_shared<std::string>();
  auto output = std::make_shared<std::string>();
  auto looks = std::make_shared<std::vector<std::string>>();
  app.add_option("avatar", *avatar, "An avatar folder (bareskin run's output)")->required();
  app.add_option("--look", *looks, "Folders written by makeup apply from this avatar (repeat or comma-separate)")
      ->delimiter(',');
  app.add_option("-o,--output", *output, "The page (default: AVATAR/viewer.html)");
  app.footer("Opens by double-click (file://, no server, no network). docs/viewer.md.\n"
             "Example:\n  bareskin viewer out/avatar --look out/looks/natural,out/looks/red_lips");
  return [=] {
    looks::viewer_command(*avatar, *looks, *output);
    spdlog::info("viewer: {}", output->empty() ? *avatar + "/viewer.html" : *output);
  };
}

}  // namespace bareskin::cli
