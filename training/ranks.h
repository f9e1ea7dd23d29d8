// The process's place among the ranks of a data-parallel run: torchrun or srun start one process per device, and
// every `train` command finds its rank, its shards and the group of the others here (docs/training.md, "Several GPUs
// and machines"). A process started alone is rank 0 of 1 and joins nothing.
#pragma once
#include <torch/types.h>

#include "training/data.h"
#include "training/distributed.h"

namespace bareskin::dist {

// How long a rank waits for the others, at the rendezvous and in every collective, before it stops with one line
// (an IoError: "rank R of N: lost the connection to another rank ..." or "... waited more than T s ..."). Set once
// per process (--dist-timeout), before world_group's first call.
constexpr int kDefaultTimeoutSeconds = 300;
void set_timeout_seconds(int seconds);

// The process's group when it was launched as one rank of several (torchrun's or SLURM's environment, world > 1):
// joined on the first call, the same group afterwards (a run of two stages trains both in it). Null for one process.
Group* world_group(torch::Device device);

// A training split's loader options for this process: its rank and the world from the environment (shard i goes to
// rank i % world; one process reads them all).
data::LoaderOptions this_rank(data::LoaderOptions options);

}  // namespace bareskin::dist
