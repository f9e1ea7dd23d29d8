// What every command shares: the global flags (-v/-q, --threads, --config), the JSON config format, the exit codes,
// and the mapping from our exceptions to one line on stderr.
#pragma once
#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/log.h"
#include "core/progress.h"
#include "training/run_flags.h"

namespace bareskin::cli {

// Exit codes, distinct per kind of failure so scripts can tell them apart.
enum ExitCode : int {
  kOk = 0,
  kInternalError = 1,  // a bug: please report it
  kUsageError = 2,     // bad flags or arguments
  kInvalidInput = 3,   // the input data is wrong
  kIoError = 4,        // a file cannot be read or written
};

struct Globals {
  bool verbose = false, quiet_flag = false;
  int threads = 0;  // 0: all cores
  std::string max_memory;  // --max-memory: what a file's header may ask for (core/memory_limit.h); "": the default
  CLI::App* root = nullptr;

  bool quiet() const { return quiet_flag; }
  // Applies -v/-q, --threads and --max-memory (logging level, thread pool, memory limit): runs before every command.
  void apply() const;
  // A progress bar unless -q.
  ProgressBar progress(const std::string& label) const { return ProgressBar(label, !quiet()); }
  // The resolved configuration (config file + flags + defaults) as JSON, and written next to a command's outputs.
  std::string resolved_config() const;
  void write_resolved_config(const std::string& path) const;
};

// A command registers its flags on `app` and returns the function that runs it once the flags are parsed.
// Groups order the listing in --help.
struct Command {
  const char* name;
  const char* group;
  const char* summary;
  std::function<std::function<void()>(CLI::App& app, const Globals& globals)> setup;
};

// The table of commands (apps/main.cc fills it from each command's register function).
const std::vector<Command>& commands();

// JSON configuration for CLI11: {"threads": 2, "template": {"vertices": 65000}}; sections are subcommands.
class JsonConfig : public CLI::Config {
 public:
  std::string to_config(const CLI::App* app, bool default_also, bool write_description, std::string prefix) const override;
  std::vector<CLI::ConfigItem> from_config(std::istream& input) const override;
  CLI::Option* file_option = nullptr;  // --config: names the file in errors
};

// A flag whose value is a JSON object (--loss, --g-options, --generator, --options, ...): {} when empty; InvalidInput
// naming the flag, with `example` as the hint, when it is not a JSON object.
nlohmann::json json_flag(const std::string& text, const std::string& flag, const std::string& example);

// The flags every training shares (training/run_flags.h). A command sets its defaults in its library's run options
// and registers them with add_trainer_flags.
using TrainerFlags = train::RunFlags;

// --steps (unless `steps` is false: the command has its own), --batch, --seed, --device, --log-every,
// --checkpoint-every, --eval-every, --sample-every, --resume.
void add_trainer_flags(CLI::App& app, TrainerFlags& flags, bool steps = true);
// --clip-grad-norm: each step's gradients scaled to at most this norm per optimizer (training/trainer.h; 0: off). The
// command's library options hold it, so that the run's configuration records it.
void add_clip_grad_norm_flag(CLI::App& app, double& norm);

// A profile: a named set of flag values a training command starts from (--profile), e.g. the network sizes a 2-core
// CPU trains in hours or the paper's for a GPU. Flags given on the command line (or in --config) win over it.
struct Profile {
  std::string name, summary;
  std::vector<std::pair<std::string, std::string>> flags;  // {"--size", "64"}, {"--g-options", "{\"ngf\": 16}"}
  // JSON-object flags of `flags` whose keys hang on another flag (the texture net's --generator on --arch): a value
  // given replaces the profile's whole instead of being merged over it.
  std::vector<std::string> replaced = {};
};
// Registers --profile NAME on `app`; `profiles` lists them, the first is the default.
void add_profile_flag(CLI::App& app, std::string& chosen, const std::vector<Profile>& profiles);
// After parsing: sets each flag of the chosen profile that was not given; a JSON object given for a flag whose
// profile value is one too is merged over it key by key (`--loss-weights '{"w3": 0}'` keeps the profile's other
// weights), unless the profile lists the flag in `replaced`. InvalidInput (before anything is written)
// for an unknown profile. Returns what a run's configuration records: {"name": ..., "overrides": {flag: value given}}
// for the profile's flags that the command line set otherwise.
nlohmann::json apply_profile(CLI::App& app, const std::string& chosen, const std::vector<Profile>& profiles);

// Parses argv, runs the chosen command, and turns exceptions into one line + exit code.
int run(int argc, char** argv);

}  // namespace bareskin::cli
