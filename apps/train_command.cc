// bareskin train: the network zoo (--list-models, --print-model) and the runs' weights for other tools (export).
// The models' own trainings (recon, bareskin, texture, upscale) are subcommands of their own issues' commands and all
// run on training/trainer.h.
#include <torch/torch.h>

#include <iostream>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "training/checkpoint.h"
#include "training/nets/zoo.h"

namespace bareskin::cli {
namespace {

// 54413955 -> "54,413,955"
std::string parameter_count(torch::nn::Module& module) {
  int64_t n = 0;
  for (const auto& p : module.parameters()) n += p.numel();
  std::string digits = std::to_string(n), out;
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

void list_models() {
  std::cout << fmt::format("{:<24} {:>14}  {}\n", "model", "parameters", "what it is");
  for (const auto& entry : nets::model_zoo()) {
    auto net = entry.make(nlohmann::json::object());
    std::cout << fmt::format("{:<24} {:>14}  {}\n", entry.name, parameter_count(*net), entry.summary);
  }
  std::cout << "\nDefaults are the paper's sizes; 'bareskin train --print-model NAME' shows the options.\n";
}

void print_model(const std::string& name, const std::string& options_text, bool structure) {
  const auto& entry = nets::find_model(name);
  nlohmann::json options = entry.defaults;
  options.update(json_flag(options_text, "--options", "{\"ngf\": 32}"));
  auto net = entry.make(options);
  std::cout << entry.name << ": " << entry.summary << "\n"
            << "parameters: " << parameter_count(*net) << "\n" << "options: " << options.dump(2) << "\n";
  if (structure) {
    std::cout << "\n" << *net << "\n";
  }
}

}  // namespace

std::function<void()> setup_train_bareskin(CLI::App& train, const Globals& globals);  // train_bareskin_command.cc
std::function<bool()> setup_train_texture(CLI::App& train, const Globals& globals);  // train_texture_command.cc
std::function<bool()> setup_train_recon(CLI::App& train, const Globals& globals);  // train_recon_command.cc

std::function<void()> setup_train_command(CLI::App& app, const Globals& globals) {
  struct Options {
    bool list = false, structure = false;
    std::string print, options, checkpoint, module, output;
  };
  auto opt = std::make_shared<Options>();
  app.add_flag("--list-models", opt->list, "List every network with its parameter count at the paper's sizes");
  app.add_option("--print-model", opt->print, "Show one network: summary, options (JSON), parameter count");
  app.add_option("--options", opt->options, "With --print-model: JSON options over the defaults, e.g. '{\"ngf\": 32}'");
  app.add_flag("--structure", opt->structure, "With --print-model: also print the module tree");
  CLI::App* e = app.add_subcommand("export", "Write a run's module as a plain state dict (reference parameter names)");
  e->add_option("checkpoint", opt->checkpoint, "A run folder (a BareSkinNet run's: its last stage) or its checkpoint")
      ->required();
  e->add_option("--module", opt->module, "Which module of the run (e.g. G, D, E)")->required();
  e->add_option("-o,--output", opt->output, "Output .safetensors (load with safetensors + load_state_dict)")->required();
  app.footer("Examples:\n  bareskin train --list-models\n  bareskin train --print-model unet256 --options "
             "'{\"ngf\": 32, \"num_downs\": 7}'\n  bareskin train export runs/bsn --module G -o G.safetensors\n"
             "docs/training.md describes the trainer, the run folder, multi-GPU and SLURM.");
  auto bareskin = setup_train_bareskin(app, globals);
  auto texture = setup_train_texture(app, globals);  // texture, upscale
  auto recon = setup_train_recon(app, globals);
  return [opt, &app, &globals, bareskin, texture, recon] {
    set_torch_threads(globals);
    if (app.got_subcommand("bareskin")) {
      bareskin();
    } else if (texture()) {
    } else if (recon()) {
    } else if (app.got_subcommand("export")) {
      const std::string checkpoint = train::run_checkpoint(opt->checkpoint);
      check_output_apart(opt->output, {opt->checkpoint, checkpoint});
      train::export_module(checkpoint, opt->module, opt->output);
      if (!globals.quiet()) std::cerr << "wrote " << opt->output << "\n";
    } else if (opt->list) {
      list_models();
    } else if (!opt->print.empty()) {
      print_model(opt->print, opt->options, opt->structure);
    } else {
      throw CLI::ValidationError("train", "give --list-models, --print-model NAME or a subcommand");
    }
  };
}

}  // namespace bareskin::cli
