// The flags every training shares (`--steps`, `--batch`, `--seed`, `--device`, ...; apps/cli.h add_trainer_flags
// registers them), as the trainings' run options hold them. No Torch here, so the commands that fill it need none.
#pragma once
#include <cstdint>
#include <string>

namespace bareskin::train {

struct RunFlags {
  int64_t steps = 1000, batch = 1, log_every = 50, checkpoint_every = 1000, eval_every = 1000, sample_every = 1000;
  uint64_t seed = 0;
  bool resume = false;
  std::string device = "cpu";  // cpu, cuda or cuda:N (training/device.h parse_device)
  void check() const;          // InvalidInput naming the flag (training/trainer.cc; the device: parse_device)
};

}  // namespace bareskin::train
