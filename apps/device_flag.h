// --device, the same on every command that runs networks (recon, demakeup, run, evaluate, landmarks detect, the
// trainings): cpu, cuda or cuda:N. The command reads it with parse_device (training/device.h) before it reads or
// writes anything.
#pragma once
#include <CLI/CLI.hpp>
#include <string>

namespace bareskin::cli {

inline CLI::Option* add_device_option(CLI::App& app, std::string& device) {
  return app.add_option("--device", device, "Where the networks run: cpu, cuda (the current CUDA device) or cuda:N")
      ->capture_default_str();
}

}  // namespace bareskin::cli
