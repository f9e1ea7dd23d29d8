// What every command shares: the global flags (-v/-q, --threads, --config), the JSON config format, the exit codes,
// and the mapping from our exceptions to one line on stderr.
#pragma once
#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

#include "core/log.h"
#include "core/progress.h"

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
  CLI::App* root = nullptr;

  bool quiet() const { return quiet_flag; }
  // Applies -v/-q and --threads (logging level, thread pool): runs before every command.
  void apply() const;
  // A progress bar unless -q.
  ProgressBar progress(const std::string& label) const { return ProgressBar(label, !quiet()); }
  // Writes the resolved configuration (config file + flags + defaults) as JSON next to a command's outputs.
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

// Parses argv, runs the chosen command, and turns exceptions into one line + exit code.
int run(int argc, char** argv);

}  // namespace bareskin::cli
