// The Gloo process group is declared only under this switch (LibTorch's CMake flags set it where it is built in).
#ifndef USE_C10D_GLOO
#define USE_C10D_GLOO
#endif
#include "training/distributed.h"

#include "training/ranks.h"

#include <torch/torch.h>
#include <torch/csrc/distributed/c10d/PrefixStore.hpp>
#include <torch/csrc/distributed/c10d/ProcessGroupGloo.hpp>
#include <torch/csrc/distributed/c10d/TCPStore.hpp>
#ifdef USE_C10D_NCCL  // set by LibTorch's CMake target where it is built with NCCL (pip's CUDA wheels)
#include <torch/csrc/distributed/c10d/ProcessGroupNCCL.hpp>
#endif

#include <cstdlib>

#include "core/error.h"

namespace bareskin::dist {
namespace {

const char* env(const char* name) {
  const char* value = std::getenv(name);
  return value && *value ? value : nullptr;
}

int env_int(const char* name, int fallback) {
  const char* value = env(name);
  if (!value) return fallback;
  char* end = nullptr;
  const long v = std::strtol(value, &end, 10);
  if (*end || v < 0) throw InvalidInput(std::string("environment ") + name, std::string("'") + value + "' is not a count",
                                        "set it to a non-negative integer (torchrun and SLURM do)");
  return int(v);
}

// A collective that failed (a rank died, hangs past the timeout, or its connection broke): one line for the user.
[[noreturn]] void lost_ranks(int rank, int world, int timeout_seconds, const std::string& operation,
                             const std::exception& e) {
  std::string reason = e.what();
  reason = reason.substr(0, reason.find('\n'));
  const bool timed_out = reason.find("imed out") != std::string::npos || reason.find("imeout") != std::string::npos;
  throw IoError("rank " + std::to_string(rank) + " of " + std::to_string(world),
                (timed_out ? "waited more than " + std::to_string(timeout_seconds) + " s for the other ranks in "
                           : "lost the connection to another rank in ") +
                    operation + " (" + reason + ")",
                "another rank died or hangs: see its log, then start every rank again with --resume (--dist-timeout "
                "sets the wait)");
}

}  // namespace

Environment Environment::from_env() {
  Environment e;
  if (env("WORLD_SIZE")) {  // torchrun
    e.world = env_int("WORLD_SIZE", 1);
    e.rank = env_int("RANK", 0);
    e.local_rank = env_int("LOCAL_RANK", 0);
  } else if (env("SLURM_NTASKS")) {
    e.world = env_int("SLURM_NTASKS", 1);
    e.rank = env_int("SLURM_PROCID", 0);
    e.local_rank = env_int("SLURM_LOCALID", 0);
  }
  if (const char* addr = env("MASTER_ADDR")) e.master_addr = addr;
  e.master_port = env_int("MASTER_PORT", 29500);
  if (e.world < 1 || e.rank >= e.world)
    throw InvalidInput("environment RANK/WORLD_SIZE", "rank " + std::to_string(e.rank) + " is outside world size " +
                                                          std::to_string(e.world),
                       "launch with torchrun or srun, which set them");
  if (e.master_port <= 0 || e.master_port > 65535)
    throw InvalidInput("environment MASTER_PORT", "is not a port", "set a free TCP port, e.g. 29500");
  return e;
}

struct Group::Impl {
  c10::intrusive_ptr<c10d::Store> store;
  // The process group: a c10d::ProcessGroup in LibTorch 1.x, a c10d::Backend in 2.x; bound through its two
  // collectives so this file builds against both.
  c10::intrusive_ptr<c10::intrusive_ptr_target> group;
  std::function<void(std::vector<torch::Tensor>&, const c10d::AllreduceOptions&)> allreduce;
  std::function<void(std::vector<torch::Tensor>&)> broadcast;
  int rank = 0, world = 1, timeout_seconds = kDefaultTimeoutSeconds;
  std::string backend;

  template <class ProcessGroup>
  void bind(c10::intrusive_ptr<ProcessGroup> pg, std::string name) {
    ProcessGroup* p = pg.get();
    allreduce = [this, p](std::vector<torch::Tensor>& t, const c10d::AllreduceOptions& o) {
      guard("an all-reduce", [&] { p->allreduce(t, o)->wait(); });
    };
    broadcast = [this, p](std::vector<torch::Tensor>& t) { guard("a broadcast", [&] { p->broadcast(t)->wait(); }); };
    group = std::move(pg);
    backend = std::move(name);
  }

  template <class F>
  void guard(const char* operation, F&& collective) {
    try {
      collective();
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {  // c10::Error, c10::DistBackendError, gloo's exceptions
      lost_ranks(rank, world, timeout_seconds, operation, e);
    }
  }
};

Group::Group(const Environment& env, torch::Device device, int timeout_seconds) : impl_(std::make_unique<Impl>()) {
  impl_->rank = env.rank;
  impl_->world = env.world;
  impl_->timeout_seconds = timeout_seconds;
  c10d::TCPStoreOptions store_options;
  store_options.port = uint16_t(env.master_port);
  store_options.isServer = env.rank == 0;
  store_options.numWorkers = size_t(env.world);
  store_options.waitWorkers = true;
  store_options.timeout = std::chrono::seconds(timeout_seconds);
  try {
    impl_->store = c10::make_intrusive<c10d::TCPStore>(env.master_addr, store_options);
  } catch (const std::exception& e) {
    throw InvalidInput("rendezvous " + env.master_addr + ":" + std::to_string(env.master_port),
                       std::string("failed (") + e.what() + ")",
                       "check MASTER_ADDR/MASTER_PORT and that every rank was started");
  }
  auto prefixed = c10::make_intrusive<c10d::PrefixStore>("bareskin", impl_->store);
  if (device.is_cuda()) {
#ifdef USE_C10D_NCCL  // set by LibTorch's CMake target where it is built with NCCL (pip's CUDA wheels)
    auto options = c10d::ProcessGroupNCCL::Options::create();
    options->timeout = std::chrono::seconds(timeout_seconds);
    impl_->bind(c10::make_intrusive<c10d::ProcessGroupNCCL>(prefixed, env.rank, env.world, options), "nccl");
#else
    throw InvalidInput("--device cuda", "distributed CUDA training needs NCCL, which this LibTorch lacks",
                       "build against a CUDA LibTorch with NCCL (docs/training.md)");
#endif
  } else {
    auto options = c10d::ProcessGroupGloo::Options::create(std::chrono::seconds(timeout_seconds));
    options->devices.push_back(c10d::ProcessGroupGloo::createDeviceForHostname(env.master_addr));
    options->threads = 2;
    impl_->bind(c10::make_intrusive<c10d::ProcessGroupGloo>(prefixed, env.rank, env.world, options), "gloo");
  }
}

Group::~Group() = default;
int Group::rank() const { return impl_->rank; }
int Group::world() const { return impl_->world; }
std::string Group::backend() const { return impl_->backend; }

void Group::broadcast(std::vector<torch::Tensor> tensors) {
  torch::NoGradGuard no_grad;
  for (auto& t : tensors) {
    std::vector<torch::Tensor> one{t.is_contiguous() ? t : t.contiguous()};
    impl_->broadcast(one);
    if (!one[0].is_same(t)) t.copy_(one[0]);
  }
}

void Group::average(std::vector<torch::Tensor> tensors, int64_t bucket_bytes) {
  torch::NoGradGuard no_grad;
  size_t begin = 0;
  while (begin < tensors.size()) {
    // A bucket: consecutive tensors of one dtype up to bucket_bytes, flattened into one buffer.
    size_t end = begin;
    int64_t bytes = 0;
    while (end < tensors.size() && tensors[end].scalar_type() == tensors[begin].scalar_type() &&
           (end == begin || bytes + int64_t(tensors[end].nbytes()) <= bucket_bytes))
      bytes += int64_t(tensors[end++].nbytes());
    std::vector<torch::Tensor> flat;
    for (size_t i = begin; i < end; ++i) flat.push_back(tensors[i].reshape(-1));
    std::vector<torch::Tensor> buffer{torch::cat(flat)};
    impl_->allreduce(buffer, c10d::AllreduceOptions{});
    buffer[0].div_(impl_->world);
    int64_t offset = 0;
    for (size_t i = begin; i < end; ++i) {
      const int64_t n = tensors[i].numel();
      tensors[i].copy_(buffer[0].narrow(0, offset, n).view_as(tensors[i]));
      offset += n;
    }
    begin = end;
  }
}

void Group::check_same(int64_t value, const std::string& what) {
  std::vector<torch::Tensor> v{torch::tensor({value, -value}, torch::kInt64)};
  c10d::AllreduceOptions options;
  options.reduceOp = c10d::ReduceOp::MAX;
  impl_->allreduce(v, options);
  const auto a = v[0].accessor<int64_t, 1>();
  if (a[0] != value || -a[1] != value)
    throw InvalidInput(what, "differs between ranks (" + std::to_string(-a[1]) + " to " + std::to_string(a[0]) + ")",
                       "start every rank with the same options and run folder");
}

namespace {
int g_timeout_seconds = kDefaultTimeoutSeconds;
}  // namespace

void set_timeout_seconds(int seconds) {
  if (seconds < 1)
    throw InvalidInput("--dist-timeout " + std::to_string(seconds), "is not a positive number of seconds",
                       "give e.g. 300");
  g_timeout_seconds = seconds;
}

data::LoaderOptions this_rank(data::LoaderOptions options) {
  const Environment env = Environment::from_env();
  options.rank = env.rank;
  options.world = env.world;
  return options;
}

Group* world_group(torch::Device device) {
  // Never destroyed: at exit, after a rank was lost, the backend's threads may still wait on the dead connection, and
  // a destructor would join them.
  static Group* group = nullptr;
  if (!group) {
    const Environment env = Environment::from_env();
    if (env.world == 1) return nullptr;
    group = new Group(env, device, g_timeout_seconds);
  }
  return group;
}

}  // namespace bareskin::dist
