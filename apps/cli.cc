#include "apps/cli.h"

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "apps/device_flag.h"
#include "core/error.h"
#include "core/files.h"
#include "core/memory_limit.h"
#include "core/parallel.h"
// The trainings' --dist-timeout (training/ranks.h), where this executable holds the trainings: the Torch side is built
// and this is not the light bareskin (BARESKIN_TORCH_EXECUTABLE names the sibling that holds them; apps/main.cc).
#if defined(BARESKIN_WITH_DETECT) && !defined(BARESKIN_TORCH_EXECUTABLE)
#define BARESKIN_HOLDS_TRAININGS
#include "training/ranks.h"
#endif

#ifndef BARESKIN_VERSION
#define BARESKIN_VERSION "unknown"
#endif

namespace bareskin::cli {
namespace {

// Thrown in the light bareskin when a command line turns out to be the Torch executable's: its command is one of the
// commands without a setup here (as CLI11 meets it, before its flags), or its --config file has a section for one (so
// that the executable that knows those flags checks them, as it always did). run() then hands the line over.
struct TorchSideCommandLine {};

bool torch_side(const std::string& command) {
  return std::any_of(commands().begin(), commands().end(),
                     [&](const Command& c) { return command == c.name && !c.setup; });
}

#ifdef BARESKIN_TORCH_EXECUTABLE
// The process becomes the Torch executable beside this one, with the same arguments (after a command link's name was
// put in): the same pid, streams, environment, output and exit code. Returns only when that cannot run.
int run_torch_side(std::vector<char*> args) {
  std::error_code ec;
  const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe", ec);
  std::string path = (self.parent_path() / BARESKIN_TORCH_EXECUTABLE).string();
  args[0] = path.data();
  args.push_back(nullptr);
  execv(path.c_str(), args.data());
  std::cerr << "error: " << path << ": " << std::strerror(errno)
            << "; the commands that reach the Torch side run in that executable, which belongs beside bareskin: "
               "rebuild or reinstall the tool (make install puts both in PREFIX/bin)\n";
  return kIoError;
}
#endif

bool is_internal_option(const CLI::Option* opt) {
  const std::string name = opt->get_name(false, true);
  return opt->get_lnames().empty() || name == "--help" || name == "--help-all" || name == "--version" ||
         name == "--config";
}

nlohmann::json option_value(const CLI::Option* opt, bool default_also) {
  std::vector<std::string> values = opt->results();
  if (values.empty() && default_also && !opt->get_default_str().empty()) values = {opt->get_default_str()};
  if (values.empty()) return nullptr;
  const auto scalar = [&](const std::string& s) -> nlohmann::json {
    if (opt->get_type_size() == 0) return s == "true" || s == "1" || s.empty();  // a flag
    const auto parsed = nlohmann::json::parse(s, nullptr, false);
    if (!parsed.is_discarded() && (parsed.is_number() || parsed.is_boolean())) return parsed;
    return s;
  };
  if (values.size() == 1 && opt->get_expected_max() <= 1) return scalar(values.front());
  nlohmann::json arr = nlohmann::json::array();
  for (const auto& v : values) arr.push_back(scalar(v));
  return arr;
}

nlohmann::json app_to_json(const CLI::App* app, bool default_also) {
  nlohmann::json out = nlohmann::json::object();
  for (const CLI::Option* opt : app->get_options()) {
    if (is_internal_option(opt)) continue;
    nlohmann::json v = option_value(opt, default_also);
    if (!v.is_null()) out[opt->get_lnames().front()] = v;
  }
  for (const CLI::App* sub : app->get_subcommands()) out[sub->get_name()] = app_to_json(sub, default_also);
  return out;
}

// The file given to --config, or "--config" before one is.
std::string config_file_name(const CLI::Option* config) {
  return config && !config->results().empty() ? config->results().back() : "--config";
}

void flatten(const nlohmann::json& j, std::vector<std::string> parents, std::vector<CLI::ConfigItem>& items) {
  for (const auto& [key, value] : j.items()) {
    if (value.is_object()) {
      auto sub = parents;
      sub.push_back(key);
      flatten(value, sub, items);
      continue;
    }
    CLI::ConfigItem item;
    item.parents = parents;
    item.name = key;
    const auto text = [](const nlohmann::json& v) { return v.is_string() ? v.get<std::string>() : v.dump(); };
    if (value.is_array()) {
      for (const auto& v : value) item.inputs.push_back(text(v));
    } else {
      item.inputs.push_back(text(value));
    }
    items.push_back(item);
  }
}

}  // namespace

std::string JsonConfig::to_config(const CLI::App* app, bool default_also, bool, std::string) const {
  return app_to_json(app, default_also).dump(2) + "\n";
}

std::vector<CLI::ConfigItem> JsonConfig::from_config(std::istream& input) const {
  nlohmann::json j = nlohmann::json::parse(input, nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    throw InvalidInput(config_file_name(file_option), "is not a JSON object of flags",
                       "write e.g. {\"threads\": 2, \"render\": {\"size\": 512}} (docs/file_formats.md, Configuration)");
  }
  std::vector<CLI::ConfigItem> items;
  flatten(j, {}, items);
  for (const CLI::ConfigItem& item : items)
    if (!item.parents.empty() && torch_side(item.parents.front())) throw TorchSideCommandLine{};
  return items;
}

void Globals::apply() const {
  init_logging(quiet_flag ? Verbosity::Quiet : verbose ? Verbosity::Verbose : Verbosity::Normal);
  set_num_threads(threads > 0 ? threads : 0);
  if (!max_memory.empty()) set_max_memory(max_memory);
}

std::string Globals::resolved_config() const { return root->config_to_str(true, false); }

void Globals::write_resolved_config(const std::string& path) const { write_file_atomic(path, resolved_config()); }

nlohmann::json json_flag(const std::string& text, const std::string& flag, const std::string& example) {
  if (text.empty()) return nlohmann::json::object();
  nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (!j.is_object()) throw InvalidInput(flag, "is not a JSON object", "e.g. " + flag + " '" + example + "'");
  return j;
}

void add_trainer_flags(CLI::App& app, TrainerFlags& f, bool steps) {
  if (steps) app.add_option("--steps", f.steps, "Training steps")->capture_default_str()->check(CLI::Range(1, 1000000000));
  app.add_option("--batch", f.batch, "Batch size")->capture_default_str();
  app.add_option("--seed", f.seed, "Seed of weights and data order (and of the run's random draws)")->capture_default_str();
  add_device_option(app, f.device);
  app.add_option("--log-every", f.log_every, "Steps between log lines")->capture_default_str();
  app.add_option("--checkpoint-every", f.checkpoint_every, "Steps between checkpoints")->capture_default_str();
  app.add_option("--eval-every", f.eval_every, "Steps between validation metrics (0: never)")->capture_default_str();
  app.add_option("--sample-every", f.sample_every, "Steps between sample grids (0: never)")->capture_default_str();
  app.add_flag("--resume", f.resume, "Continue the run in the output folder from its checkpoint");
#ifdef BARESKIN_HOLDS_TRAININGS
  app.add_option_function<int>("--dist-timeout", dist::set_timeout_seconds,
                               "Started as several ranks (torchrun, srun): seconds a rank waits for the others before "
                               "it stops with one line")
      ->default_str(std::to_string(dist::kDefaultTimeoutSeconds))
      ->check(CLI::Range(1, 86400));
#endif
}

void add_clip_grad_norm_flag(CLI::App& app, double& norm) {
  app.add_option("--clip-grad-norm", norm, "Scale each step's gradients to at most this norm (0: off); keeps a "
                 "gradient spike from throwing the net off. The norm before clipping is logged as <net>/grad_norm")
      ->capture_default_str();
}

void add_profile_flag(CLI::App& app, std::string& chosen, const std::vector<Profile>& profiles) {
  chosen = profiles.front().name;
  std::string help = "Sizes and recipe to start from (flags given win):";
  for (const Profile& p : profiles) help += "\n  " + p.name + ": " + p.summary;
  app.add_option("--profile", chosen, help)->capture_default_str();
}

nlohmann::json apply_profile(CLI::App& app, const std::string& chosen, const std::vector<Profile>& profiles) {
  const auto found = std::find_if(profiles.begin(), profiles.end(), [&](const Profile& p) { return p.name == chosen; });
  if (found == profiles.end()) {
    std::string names;
    for (const Profile& p : profiles) names += (names.empty() ? "" : ", ") + p.name;
    throw InvalidInput("--profile " + chosen, "is not a profile of '" + app.get_name() + "'", "use one of " + names);
  }
  nlohmann::json overrides = nlohmann::json::object();
  for (const auto& [flag, value] : found->flags) {
    CLI::Option* option = app.get_option(flag);
    if (option->count() > 0) {
      const auto given = option->results();
      const std::string text = given.size() == 1 ? given.front() : CLI::detail::join(given, " ");
      overrides[flag] = text;
      // A JSON object given for a flag the profile sets to one (--g-options, --loss-weights, ...) adds its keys to
      // the profile's and wins where both have one: the profile's other keys stay.
      const auto profile_value = nlohmann::json::parse(value, nullptr, false);
      const auto given_value = nlohmann::json::parse(text, nullptr, false);
      const bool replaced = std::count(found->replaced.begin(), found->replaced.end(), flag) > 0;
      if (profile_value.is_object() && given_value.is_object() && !replaced) {
        nlohmann::json merged = profile_value;
        merged.update(given_value);
        option->clear();
        option->add_result(merged.dump());
        option->run_callback();
      }
      continue;
    }
    option->clear();
    option->add_result(value);
    option->run_callback();
  }
  return {{"name", found->name}, {"overrides", overrides}};
}

int run(int argc, char** argv) {
  // Page faults are expensive on our VMs: keep large allocations in the heap instead of fresh mmaps (docs/environment.md).
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  // A write past the file size limit (ulimit -f, a quota) fails with EFBIG and becomes one line naming the file,
  // as a full disk does, instead of killing the process mid-write.
  std::signal(SIGXFSZ, SIG_IGN);

  // Multi-call: invoked as `uvtools ...` (a link to bareskin) means `bareskin uvtools ...`.
  std::vector<char*> args(argv, argv + argc);
  const std::string invoked = std::filesystem::path(argv[0]).filename().string();
  std::string invoked_copy = invoked;
  for (const Command& c : commands()) {
    if (invoked == c.name) {
      args.insert(args.begin() + 1, invoked_copy.data());
      break;
    }
  }

  CLI::App app("BareSkin toolkit: scans to a 3D morphable model, training data and relightable face textures.\n"
               "Run 'bareskin COMMAND --help' for a command's flags; docs/cli.md lists them all.",
               "bareskin");
  Globals globals;
  globals.root = &app;
  app.set_version_flag("--version", std::string("bareskin ") + BARESKIN_VERSION);
  app.require_subcommand(1);
  app.fallthrough();
  auto config = std::make_shared<JsonConfig>();
  app.config_formatter(config);
  config->file_option = app.set_config("--config", "", "Read flags from a JSON file (flags on the command line win)");
  config->file_option->group("Global");
  app.allow_config_extras(CLI::config_extras_mode::error);  // a misspelt key is refused, not ignored (subcommands inherit)
  app.add_flag("-v,--verbose", globals.verbose, "More log output")->group("Global");
  app.add_flag("-q,--quiet", globals.quiet_flag, "Only warnings and errors; no progress bars")->group("Global");
  app.add_option("--threads", globals.threads, "Worker threads (0: all cores)")->check(CLI::Range(0, 4096))->group("Global");
  app.add_option("--max-memory", globals.max_memory,
                 "Most memory a file's header may ask for before it is read, e.g. 8G (default: BARESKIN_MAX_MEMORY, else 8G)")
      ->group("Global");
  for (const Command& c : commands()) {
    CLI::App* sub = app.add_subcommand(c.name, c.summary)->group(c.group);
    if (!c.setup) {  // the Torch executable's command (apps/main.cc): handed over as soon as it is met
      sub->preparse_callback([](size_t) { throw TorchSideCommandLine{}; });
      continue;
    }
    sub->footer("Global flags (before or after the command): -v, -q, --threads N, --max-memory 8G, --config FILE.json; "
                "see 'bareskin --help' and docs/cli.md.");
    sub->callback([&globals, run_command = c.setup(*sub, globals)] {
      globals.apply();
      run_command();
    });
  }
  // CLI11's range checks let NaN through (every comparison with it is false): no flag takes NaN or an infinity.
  for (size_t i = 1; i < args.size(); ++i) {
    std::string value = args[i];
    const size_t eq = value.find('=');
    if (value.rfind("--", 0) == 0 && eq != std::string::npos) value = value.substr(eq + 1);
    std::transform(value.begin(), value.end(), value.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (!value.empty() && (value[0] == '+' || value[0] == '-')) value.erase(0, 1);
    if (value == "nan" || value == "inf" || value == "infinity") {
      std::cerr << "bareskin: '" << args[i] << "' is not a finite number; flags take finite values (see --help)\n";
      return kUsageError;
    }
  }
  if (args.size() > 1 && args[1][0] != '-') {
    const std::string first = args[1];
    const bool known = std::any_of(commands().begin(), commands().end(), [&](const Command& c) { return first == c.name; });
    if (!known) {
      std::string names;
      for (const Command& c : commands()) names += (names.empty() ? "" : ", ") + std::string(c.name);
      std::cerr << "bareskin: unknown command '" << first << "'; commands are " << names << " (see --help)\n";
      return kUsageError;
    }
  }
  try {
    app.parse(int(args.size()), args.data());
#ifdef BARESKIN_TORCH_EXECUTABLE
  } catch (const TorchSideCommandLine&) {
    return run_torch_side(args);
#endif
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ConfigError& e) {  // a key of the --config file that is no flag of bareskin or of its command
    const std::string prefix = "INI was not able to parse ", what = e.what();
    std::cerr << "error: " << config_file_name(app.get_config_ptr()) << ": "
              << (what.rfind(prefix, 0) == 0 ? "'" + what.substr(prefix.size()) + "' is not a flag" : what)
              << "; spell flags as --help does, a command's in its object: {\"template\": {\"vertices\": 30000}}\n";
    return kUsageError;
  } catch (const CLI::ParseError& e) {
    std::cerr << "bareskin: " << e.what() << " (see --help)\n";
    return kUsageError;
  } catch (const InvalidInput& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kInvalidInput;
  } catch (const IoError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kIoError;
  } catch (const InternalError& e) {
    std::cerr << "internal error: " << e.what() << " (please report this)\n";
    return kInternalError;
  } catch (const std::filesystem::filesystem_error& e) {  // e.g. an output folder asked for where a file is
    std::cerr << "error: " << e.path1().string() << ": " << e.code().message()
              << "; check that the path's folders exist, are folders and are writable\n";
    return kIoError;
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory; try a smaller size or fewer --threads\n";
    return kIoError;
  } catch (const std::exception& e) {
    std::cerr << "internal error: " << e.what() << " (please report this)\n";
    return kInternalError;
  }
  return kOk;
}

}  // namespace bareskin::cli
