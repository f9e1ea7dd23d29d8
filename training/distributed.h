// Data-parallel training on PyTorch's own c10d: a TCPStore rendezvous and a process group (Gloo on the CPU, NCCL on
// CUDA where LibTorch has it). Ranks come from torchrun's environment (RANK, WORLD_SIZE, LOCAL_RANK, MASTER_ADDR,
// MASTER_PORT) or SLURM's (SLURM_PROCID, SLURM_NTASKS, SLURM_LOCALID; MASTER_ADDR/MASTER_PORT as set by the batch
// script). One process per device; every rank reads its own shards.
#pragma once
#include <torch/types.h>

#include <memory>
#include <string>
#include <vector>

namespace bareskin::dist {

struct Environment {
  int rank = 0, world = 1, local_rank = 0;
  std::string master_addr = "127.0.0.1";
  int master_port = 29500;
  // From torchrun's or SLURM's variables; world 1 when neither is set. InvalidInput for inconsistent values.
  static Environment from_env();
};

class Group {
 public:
  // Joins the group (blocks until every rank has joined; InvalidInput after `timeout_seconds`).
  Group(const Environment& env, torch::Device device, int timeout_seconds = 300);
  ~Group();
  int rank() const;
  int world() const;
  std::string backend() const;
  // Rank 0's values everywhere (parameters and buffers at the start).
  void broadcast(std::vector<torch::Tensor> tensors);
  // Sum over ranks, divided by the world size, in buckets of about `bucket_bytes` (gradients after backward).
  void average(std::vector<torch::Tensor> tensors, int64_t bucket_bytes = 25 << 20);
  // The same integer on every rank? (checked at start: world size and step of a resumed run).
  void check_same(int64_t value, const std::string& what);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace bareskin::dist
