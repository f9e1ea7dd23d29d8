#include "training/checkpoint.h"

#include <ATen/CPUGeneratorImpl.h>

#include <filesystem>
#include <regex>
#include <set>

#include "core/error.h"
#include "core/safetensors.h"
#include "training/tensor_io.h"

namespace bareskin::train {

std::string checkpoint_path(const std::string& run_dir) { return run_dir + "/checkpoint.safetensors"; }

namespace {

constexpr const char* kMetadata = "bareskin.checkpoint";
constexpr const char* kHint = "resume with the run's own configuration, or start a new run folder";

std::string state_key(const torch::Tensor& p) { return c10::guts::to_string(p.unsafeGetTensorImpl()); }

template <class ParamState>
void save_adam(const std::string& prefix, torch::optim::Optimizer& optimizer, std::map<std::string, torch::Tensor>& out) {
  auto& groups = optimizer.param_groups();
  for (size_t g = 0; g < groups.size(); ++g)
    for (size_t i = 0; i < groups[g].params().size(); ++i) {
      auto it = optimizer.state().find(state_key(groups[g].params()[i]));
      if (it == optimizer.state().end()) continue;
      const auto& st = static_cast<const ParamState&>(*it->second);
      const std::string name = prefix + "." + std::to_string(g) + "." + std::to_string(i) + ".";
      out[name + "exp_avg"] = st.exp_avg();
      out[name + "exp_avg_sq"] = st.exp_avg_sq();
      out[name + "step"] = torch::tensor({st.step()}, torch::kInt64);
    }
}

template <class ParamState>
void load_adam(const std::string& prefix, torch::optim::Optimizer& optimizer,
               std::map<std::string, torch::Tensor>& in, const std::string& path) {
  auto& groups = optimizer.param_groups();
  for (size_t g = 0; g < groups.size(); ++g)
    for (size_t i = 0; i < groups[g].params().size(); ++i) {
      const auto& p = groups[g].params()[i];
      const std::string name = prefix + "." + std::to_string(g) + "." + std::to_string(i) + ".";
      auto avg = in.find(name + "exp_avg");
      if (avg == in.end()) continue;  // the parameter had no step yet
      auto sq = in.find(name + "exp_avg_sq"), step = in.find(name + "step");
      if (sq == in.end() || step == in.end() || !avg->second.sizes().equals(p.sizes()))
        throw InvalidInput(path, "optimizer state '" + name + "*' does not fit this net", kHint);
      auto st = std::make_unique<ParamState>();
      st->step(step->second.item<int64_t>());
      st->exp_avg(avg->second.to(p.device()).clone());
      st->exp_avg_sq(sq->second.to(p.device()).clone());
      optimizer.state()[state_key(p)] = std::move(st);
      in.erase(avg), in.erase(sq), in.erase(step);
    }
}

// The first key (a/b/c) whose value differs between two configurations, skipping resumable keys; "" if none.
std::string first_difference(const nlohmann::json& a, const nlohmann::json& b, const std::vector<std::string>& skip,
                             const std::string& path = "") {
  if (a.is_object() && b.is_object()) {
    std::set<std::string> keys;
    for (auto it = a.begin(); it != a.end(); ++it) keys.insert(it.key());
    for (auto it = b.begin(); it != b.end(); ++it) keys.insert(it.key());
    for (const auto& k : keys) {
      if (std::find(skip.begin(), skip.end(), k) != skip.end()) continue;
      const std::string sub = path.empty() ? k : path + "." + k;
      if (!a.contains(k) || !b.contains(k)) return sub;
      auto d = first_difference(a[k], b[k], skip, sub);
      if (!d.empty()) return d;
    }
    return "";
  }
  return a == b ? "" : (path.empty() ? "(root)" : path);
}

void module_tensors(const std::string& name, const torch::nn::Module& module,
                    std::map<std::string, torch::Tensor>& out) {
  for (const auto& p : module.named_parameters()) out["module." + name + "." + p.key()] = p.value();
  for (const auto& b : module.named_buffers()) out["module." + name + "." + b.key()] = b.value();
}

}  // namespace

void save_checkpoint(const std::string& path, const Checkpoint& checkpoint,
                     const std::map<std::string, std::shared_ptr<torch::nn::Module>>& modules,
                     const std::vector<OptimizerSpec>& specs,
                     const std::vector<std::unique_ptr<torch::optim::Optimizer>>& optimizers) {
  std::map<std::string, torch::Tensor> tensors;
  for (const auto& [name, module] : modules) module_tensors(name, *module, tensors);
  for (size_t o = 0; o < optimizers.size(); ++o) {
    const std::string prefix = "optim." + specs[o].name;
    if (specs[o].kind == "adamw") save_adam<torch::optim::AdamWParamState>(prefix, *optimizers[o], tensors);
    else save_adam<torch::optim::AdamParamState>(prefix, *optimizers[o], tensors);
  }
  {
    auto gen = at::detail::getDefaultCPUGenerator();
    std::lock_guard<std::mutex> lock(gen.mutex());
    tensors["rng.cpu"] = gen.get_state();
  }
  if (torch::cuda::is_available())
    for (int64_t d = 0; d < int64_t(torch::cuda::device_count()); ++d) {
      auto gen = at::globalContext().defaultGenerator(torch::Device(torch::kCUDA, d));
      std::lock_guard<std::mutex> lock(gen.mutex());
      tensors["rng.cuda." + std::to_string(d)] = gen.get_state();
    }
  const nlohmann::json meta = {{"step", checkpoint.step},   {"task", checkpoint.task},
                               {"config", checkpoint.config}, {"cursor", data::to_json(checkpoint.cursor)},
                               {"world", checkpoint.world},   {"trainer", checkpoint.trainer}};
  save_tensors(path, tensors, {{kMetadata, meta.dump()}});
}

namespace {
nlohmann::json read_metadata(const SafeTensors& file) {
  auto it = file.metadata().find(kMetadata);
  if (it == file.metadata().end())
    throw InvalidInput(file.source(), "is not a training checkpoint (no '" + std::string(kMetadata) + "' metadata)", kHint);
  nlohmann::json meta = nlohmann::json::parse(it->second, nullptr, false);
  if (meta.is_discarded() || !meta.is_object() || !meta.contains("step") || !meta["step"].is_number_integer() ||
      !meta.contains("task") || !meta["task"].is_string() || !meta.contains("config")) {
    throw InvalidInput(file.source(), "has damaged checkpoint metadata (not JSON with step, task and config)",
                       "the file is not what training wrote: use the run's checkpoint or retrain");
  }
  return meta;
}
}  // namespace

int64_t read_checkpoint_step(const std::string& path) {
  return read_metadata(SafeTensors::open(path)).at("step").get<int64_t>();
}

Checkpoint load_checkpoint(const std::string& path, const std::string& task, const nlohmann::json& config,
                           const std::vector<std::string>& resumable_keys,
                           const std::map<std::string, std::shared_ptr<torch::nn::Module>>& modules,
                           const std::vector<OptimizerSpec>& specs,
                           std::vector<std::unique_ptr<torch::optim::Optimizer>>& optimizers, int world,
                           const std::function<void(nlohmann::json&)>& upgrade) {
  Checkpoint c;
  {
    const nlohmann::json meta = read_metadata(SafeTensors::open(path));
    c.step = meta.at("step").get<int64_t>();
    c.task = meta.at("task").get<std::string>();
    c.config = meta.at("config");
    c.cursor = data::cursor_from_json(meta.at("cursor"));
    c.world = meta.at("world").get<int>();
    c.trainer = meta.value("trainer", nlohmann::json::object());
  }
  if (c.task != task)  // before the upgrade, which reads the configuration as this task's
    throw InvalidInput(path, "is a checkpoint of '" + c.task + "', not '" + task + "'", kHint);
  if (upgrade) upgrade(c.config);
  const std::string diff = first_difference(c.config, config, resumable_keys);
  if (!diff.empty()) {
    const nlohmann::json::json_pointer pointer("/" + std::regex_replace(diff, std::regex("\\."), "/"));
    auto show = [&](const nlohmann::json& j) { return j.contains(pointer) ? j[pointer].dump() : std::string("unset"); };
    throw InvalidInput(path, "was written with another configuration ('" + diff + "': " + show(c.config) +
                                 " there, " + show(config) + " now)",
                       kHint);
  }
  if (c.world != world)
    throw InvalidInput(path, "was written by " + std::to_string(c.world) + " rank(s), this run has " +
                                 std::to_string(world),
                       "resume with the same number of processes (the data order depends on it)");
  auto tensors = load_tensors(path);
  torch::NoGradGuard no_grad;
  for (const auto& [name, module] : modules) {
    std::map<std::string, torch::Tensor> mine;
    module_tensors(name, *module, mine);
    for (auto& [key, target] : mine) {
      auto it = tensors.find(key);
      if (it == tensors.end())
        throw InvalidInput(path, "has no tensor '" + key + "' (a checkpoint of another net)", kHint);
      if (!it->second.sizes().equals(target.sizes()))
        throw InvalidInput(path, "tensor '" + key + "' has another shape (a checkpoint of another net)", kHint);
      target.copy_(it->second);
      tensors.erase(it);
    }
  }
  for (size_t o = 0; o < optimizers.size(); ++o) {
    const std::string prefix = "optim." + specs[o].name;
    if (specs[o].kind == "adamw") load_adam<torch::optim::AdamWParamState>(prefix, *optimizers[o], tensors, path);
    else load_adam<torch::optim::AdamParamState>(prefix, *optimizers[o], tensors, path);
  }
  {
    auto it = tensors.find("rng.cpu");
    if (it == tensors.end()) throw InvalidInput(path, "has no 'rng.cpu' state", kHint);
    auto gen = at::detail::getDefaultCPUGenerator();
    std::lock_guard<std::mutex> lock(gen.mutex());
    gen.set_state(it->second);
    tensors.erase(it);
  }
  for (auto it = tensors.begin(); it != tensors.end();) {
    if (it->first.rfind("rng.cuda.", 0) == 0) {
      const int d = std::stoi(it->first.substr(9));
      if (torch::cuda::is_available() && d < int(torch::cuda::device_count())) {
        auto gen = at::globalContext().defaultGenerator(torch::Device(torch::kCUDA, d));
        std::lock_guard<std::mutex> lock(gen.mutex());
        gen.set_state(it->second);
      }
      it = tensors.erase(it);
    } else {
      ++it;
    }
  }
  if (!tensors.empty())
    throw InvalidInput(path, "holds tensor '" + tensors.begin()->first + "' that this net lacks (a checkpoint of another net)",
                       kHint);
  return c;
}

void load_module_weights(const std::string& path, const std::string& name, torch::nn::Module& module) {
  auto tensors = load_tensors(path);
  std::map<std::string, torch::Tensor> mine;
  module_tensors(name, module, mine);
  torch::NoGradGuard no_grad;
  for (auto& [key, target] : mine) {
    auto it = tensors.find(key);
    if (it == tensors.end() || !it->second.sizes().equals(target.sizes()))
      throw InvalidInput(path, "has no tensor '" + key + "' of this net's shape (a checkpoint of another net)",
                         "give the checkpoint of a run of this model");
    target.copy_(it->second);
  }
}

std::string run_checkpoint(const std::string& run) {
  if (!std::filesystem::is_directory(run)) return run;
  for (const char* stage : {"/stage2", "/stage1"}) {
    const std::string path = checkpoint_path(run + stage);
    if (std::filesystem::exists(path)) return path;
  }
  return checkpoint_path(run);
}

void export_module(const std::string& checkpoint, const std::string& name, const std::string& output) {
  const SafeTensors file = SafeTensors::open(checkpoint);
  const nlohmann::json meta = read_metadata(file);
  std::map<std::string, torch::Tensor> tensors;
  std::set<std::string> modules;
  const std::string prefix = "module." + name + ".";
  for (const auto& key : file.names()) {
    if (key.rfind("module.", 0) == 0) modules.insert(key.substr(7, key.find('.', 7) - 7));
    if (key.rfind(prefix, 0) == 0) tensors[key.substr(prefix.size())] = to_tensor(file.tensor(key), checkpoint);
  }
  if (tensors.empty()) {
    std::string names;
    for (const auto& m : modules) names += (names.empty() ? "" : ", ") + m;
    throw InvalidInput(checkpoint, "has no module '" + name + "' (it holds: " + names + ")", "pass one of those to --module");
  }
  save_tensors(output, tensors,
               {{"module", name}, {"task", meta.at("task").get<std::string>()},
                {"step", std::to_string(meta.at("step").get<int64_t>())}, {"config", meta.at("config").dump()}});
}

}  // namespace bareskin::train
