// bareskin inspect: what a file holds (mesh, image, safetensors, landmarks), as text or JSON (core/inspect.h).
#include <iostream>
#include <memory>

#include "apps/cli.h"
#include "core/inspect.h"

namespace bareskin::cli {

std::function<void()> setup_inspect_command(CLI::App& app, const Globals&) {
  struct Options {
    std::vector<std::string> files;
    bool json = false, stats = false, values = false;
  };
  auto opt = std::make_shared<Options>();
  app.add_option("files", opt->files, "Meshes (.obj .ply), images, .safetensors, landmarks (.json .pts)")->required();
  app.add_flag("--json", opt->json, "Print one JSON object per file");
  app.add_flag("--stats", opt->stats, "Tensor min/max/mean (safetensors)");
  app.add_flag("--values", opt->values, "With --json: every tensor element, row-major (safetensors; small files)");
  return [opt] {
    for (const std::string& f : opt->files) {
      const nlohmann::json j = inspect_file(f, opt->stats, opt->values && opt->json);
      if (opt->json) {
        std::cout << j.dump() << "\n";
      } else {
        std::cout << inspect_text(j);
      }
    }
  };
}

}  // namespace bareskin::cli
