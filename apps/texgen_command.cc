// bareskin texgen: the dataset generators, one subcommand each in its own file (flags + run function), registered
// below with one line: `faces` (the face-image world with truth, apps/texgen_faces_command.cc), `ingest-pairs` and
// `show` (real before/after photos into shards, contact sheets; apps/texgen_ingest_command.cc), `make-dataset` (UV
// texture samples, apps/texgen_dataset_command.cc), `run-dataset` (texture samples through the run pipeline, where
// the avatar side is built). Each setup returns a run function that does nothing unless its subcommand was parsed.
#include <functional>
#include <vector>

#include "apps/cli.h"

namespace bareskin::cli {

using TexgenSetup = std::function<void()> (*)(CLI::App& texgen, const Globals& globals);

// One declaration per subcommand file (defined there).
std::function<void()> setup_texgen_faces(CLI::App& texgen, const Globals& globals);
std::function<void()> setup_texgen_make_dataset(CLI::App& texgen, const Globals& globals);
std::function<void()> setup_texgen_ingest_pairs(CLI::App& texgen, const Globals& globals);
std::function<void()> setup_texgen_show(CLI::App& texgen, const Globals& globals);
#ifdef BARESKIN_WITH_AVATAR
std::function<void()> setup_texgen_run_dataset(CLI::App& texgen, const Globals& globals);
#endif

std::function<void()> setup_texgen_command(CLI::App& app, const Globals& globals) {
  static const TexgenSetup setups[] = {
      setup_texgen_faces,  // texgen faces
      setup_texgen_make_dataset,  // texgen make-dataset (apps/texgen_dataset_command.cc)
      setup_texgen_ingest_pairs,  // texgen ingest-pairs (apps/texgen_ingest_command.cc)
      setup_texgen_show,  // texgen show (apps/texgen_ingest_command.cc)
#ifdef BARESKIN_WITH_AVATAR
      setup_texgen_run_dataset,  // texgen run-dataset (apps/texgen_run_dataset_command.cc)
#endif
  };
  app.require_subcommand(1);
  std::vector<std::function<void()>> runs;
  for (TexgenSetup setup : setups) runs.push_back(setup(app, globals));
  return [runs] {
    for (const auto& run : runs) run();  // only the parsed subcommand's does anything
  };
}

}  // namespace bareskin::cli
