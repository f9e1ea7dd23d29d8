#include "training/data.h"

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <exception>
#include <mutex>
#include <random>
#include <thread>

#include "core/error.h"
#include "core/ibug68.h"
#include "core/png.h"
#include "core/shards.h"

namespace bareskin::data {
namespace {

// A well-mixed 64-bit value from a few integers (SplitMix64 steps): seeds per (seed, epoch, rank, index).
uint64_t mix(std::initializer_list<uint64_t> values) {
  uint64_t h = 0x9e3779b97f4a7c15ull;
  for (uint64_t v : values) {
    h ^= v + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
    h += 0x9e3779b97f4a7c15ull;
    uint64_t z = h;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    h = z ^ (z >> 31);
  }
  return h;
}

torch::Tensor image_tensor(const Image& image) {
  auto hwc = torch::from_blob(const_cast<float*>(image.pixels.data()), {image.height, image.width, image.channels},
                              torch::kFloat32);
  // clone(): for one channel the permuted view is already contiguous, and contiguous() would return a view of
  // `image`'s pixels, which the caller frees.
  return hwc.permute({2, 0, 1}).clone(torch::MemoryFormat::Contiguous);
}

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

}  // namespace

const torch::Tensor& Batch::at(const std::string& name) const {
  auto it = tensors.find(name);
  if (it == tensors.end())
    throw InvalidInput("batch", "has no member '" + name + "'", "generate the dataset with that member");
  return it->second;
}

Batch collate(const std::vector<Example>& examples) {
  BS_CHECK(!examples.empty(), "a batch needs examples");
  Batch batch;
  for (const auto& [name, tensor] : examples[0].tensors) {
    std::vector<torch::Tensor> parts;
    for (const auto& e : examples) {
      auto it = e.tensors.find(name);
      if (it == e.tensors.end())
        throw InvalidInput("sample '" + e.key + "'", "lacks '" + name + "', which sample '" + examples[0].key + "' has",
                           "regenerate the dataset so every sample has the same members");
      if (!it->second.sizes().equals(tensor.sizes()))
        throw InvalidInput("sample '" + e.key + "'", "member '" + name + "' has another size than in sample '" +
                                                         examples[0].key + "'",
                           "regenerate the dataset at one size");
      parts.push_back(it->second);
    }
    batch.tensors[name] = torch::stack(parts);
  }
  for (const auto& e : examples) {
    batch.keys.push_back(e.key);
    batch.meta.push_back(e.meta);
  }
  return batch;
}

Example decode_sample(const std::string& key, const std::map<std::string, std::string>& members,
                      const std::string& source) {
  Example example;
  example.key = key;
  for (const auto& [suffix, bytes] : members) {
    const std::string where = source + ": " + key + "." + suffix;
    if (ends_with(suffix, ".png") || suffix == "png") {
      const std::string name = suffix == "png" ? "png" : suffix.substr(0, suffix.size() - 4);
      example.tensors[name] = image_tensor(decode_png(bytes, where));
    } else if (suffix == "json") {
      try {
        example.meta = nlohmann::json::parse(bytes);
        if (example.meta.contains("landmarks")) {
          const auto& lm = example.meta["landmarks"];
          auto points = torch::empty({int64_t(lm.size()), 2});
          auto a = points.accessor<float, 2>();
          for (size_t i = 0; i < lm.size(); ++i) {
            a[i][0] = lm[i].at(0).get<float>();
            a[i][1] = lm[i].at(1).get<float>();
          }
          example.tensors["landmarks"] = points;
        }
      } catch (const nlohmann::json::exception& e) {
        throw InvalidInput(where, std::string("malformed JSON (") + e.what() + ")", "regenerate the shard");
      }
    }
  }
  return example;
}

const std::vector<int64_t>& ibug68_mirror() {
  static const std::vector<int64_t> mirror(kIbug68Mirror.begin(), kIbug68Mirror.end());
  return mirror;
}

void augment_example(Example& example, const Augment& augment, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double range) { return (2 * unit(rng) - 1) * range; };
  const bool flip = unit(rng) < augment.flip_probability;
  const double s = 1 + uniform(augment.scale);
  const double angle = uniform(augment.rotate_degrees) * M_PI / 180;
  const double tx = uniform(augment.shift_pixels), ty = uniform(augment.shift_pixels);
  const double c = std::cos(angle), sn = std::sin(angle);
  const double f = flip ? -1 : 1;
  // Forward map of a pixel position p (continuous, origin at the top-left corner) about the centre o:
  // p' = o + s R F (p - o) + t, F = diag(f, 1). Rows of A = s R F:
  const double a00 = s * c * f, a01 = -s * sn, a10 = s * sn * f, a11 = s * c;

  int64_t ref_w = 0, ref_h = 0;
  for (auto& [name, t] : example.tensors) {
    if (t.dim() != 3) continue;
    const int64_t h = t.size(1), w = t.size(2);
    if (!ref_w) ref_w = w, ref_h = h;
    // The shift is given at the first image's size; other members scale it to theirs.
    const double sx = tx * w / ref_w, sy = ty * h / ref_h;
    // Output pixel u' (normalised, align_corners = false) to input u: u = D^-1 A^-1 (D u' - t), D = diag(w/2, h/2).
    const double det = a00 * a11 - a01 * a10;
    const double i00 = a11 / det, i01 = -a01 / det, i10 = -a10 / det, i11 = a00 / det;
    const double dx = w / 2.0, dy = h / 2.0;
    const double m00 = i00, m01 = i01 * dy / dx, m10 = i10 * dx / dy, m11 = i11;
    const double b0 = -(i00 * sx + i01 * sy) / dx, b1 = -(i10 * sx + i11 * sy) / dy;
    auto theta = torch::tensor({m00, m01, b0, m10, m11, b1}, torch::kFloat64).to(torch::kFloat32).view({1, 2, 3});
    auto grid = torch::nn::functional::affine_grid(theta, {1, t.size(0), h, w}, /*align_corners=*/false);
    const bool nearest = std::find(augment.nearest.begin(), augment.nearest.end(), name) != augment.nearest.end();
    namespace F = torch::nn::functional;
    F::GridSampleFuncOptions::mode_t mode = torch::kBilinear;
    if (nearest) mode = torch::kNearest;
    t = F::grid_sample(t.unsqueeze(0), grid,
                       F::GridSampleFuncOptions()
                           .mode(mode)
                           .padding_mode(torch::kZeros)
                           .align_corners(false))
            .squeeze(0);
  }
  auto it = example.tensors.find("landmarks");
  if (it != example.tensors.end()) {
    auto& lm = it->second;
    if (flip && lm.size(0) != 68)
      throw InvalidInput("sample '" + example.key + "'", "has " + std::to_string(lm.size(0)) +
                                                             " landmarks; a flip needs the iBUG-68 set",
                         "turn flips off for this dataset");
    const double ox = ref_w / 2.0, oy = ref_h / 2.0;
    auto x = lm.select(1, 0).to(torch::kFloat64) - ox, y = lm.select(1, 1).to(torch::kFloat64) - oy;
    auto out = torch::stack({ox + a00 * x + a01 * y + tx, oy + a10 * x + a11 * y + ty}, 1).to(torch::kFloat32);
    if (flip) out = out.index_select(0, torch::tensor(ibug68_mirror()));
    lm = out;
  }
}

nlohmann::json to_json(const Cursor& cursor) { return {{"epoch", cursor.epoch}, {"index", cursor.index}}; }
Cursor cursor_from_json(const nlohmann::json& j) { return {j.at("epoch").get<int64_t>(), j.at("index").get<int64_t>()}; }

// ---- the pipeline: one reader thread (shards -> shuffle buffer), decode threads, an ordered hand-over ----

struct ShardLoader::Pipeline {
  struct Raw {
    int64_t sequence, epoch, index;
    shards::Sample sample;
    std::string source;
  };
  struct Done {
    int64_t epoch, index;
    Example example;
  };

  const LoaderOptions& options;
  const std::vector<std::string>& shard_files;
  const int64_t epoch_size;
  std::mutex mutex;
  std::condition_variable changed;
  std::deque<Raw> raw;            // read, waiting for a decoder
  std::map<int64_t, Done> done;   // decoded, by sequence number
  int64_t next_sequence = 0;      // the consumer's next
  bool stop = false;
  std::exception_ptr error;
  std::vector<std::thread> threads;
  const size_t capacity;

  Pipeline(const LoaderOptions& o, const std::vector<std::string>& files, int64_t size, Cursor start)
      : options(o), shard_files(files), epoch_size(size),
        capacity(size_t(std::max<int64_t>(2 * o.batch_size, 4 * std::max(1, o.decode_threads)))) {
    threads.emplace_back([this, start] { guard([&] { read(start); }); });
    for (int i = 0; i < std::max(1, options.decode_threads); ++i)
      threads.emplace_back([this] { guard([&] { decode(); }); });
  }
  ~Pipeline() {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
    }
    changed.notify_all();
    for (auto& t : threads) t.join();
  }

  template <class F>
  void guard(F&& body) {
    try {
      body();
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
      stop = true;
      changed.notify_all();
    }
  }

  // Reader: epochs from `start` on; the first start.index examples of the first epoch are skipped undecoded.
  void read(Cursor start) {
    int64_t sequence = 0;
    for (int64_t epoch = start.epoch;; ++epoch) {
      std::vector<std::string> order = shard_files;
      std::mt19937_64 rng(mix({options.seed, uint64_t(epoch), uint64_t(options.rank)}));
      if (options.shuffle_buffer > 0) std::shuffle(order.begin(), order.end(), rng);
      std::vector<std::pair<shards::Sample, std::string>> buffer;
      int64_t index = 0;
      auto emit = [&](std::pair<shards::Sample, std::string>&& item) {
        const int64_t i = index++;
        if (epoch == start.epoch && i < start.index) return true;
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock, [&] { return stop || raw.size() + done.size() < capacity; });
        if (stop) return false;
        raw.push_back({sequence++, epoch, i, std::move(item.first), std::move(item.second)});
        changed.notify_all();
        return true;
      };
      for (const auto& file : order) {
        shards::ShardReader reader(file);
        shards::Sample sample;
        while (reader.next(sample)) {
          for (const auto& member : options.required)
            if (!sample.members.count(member))
              throw InvalidInput(file, "sample '" + sample.key + "' has no member '" + member + "'",
                                 "regenerate the shard (its generator resumes) or drop it from manifest.json");
          if (!options.decode.empty())
            for (auto it = sample.members.begin(); it != sample.members.end();)
              it = std::find(options.decode.begin(), options.decode.end(), it->first) == options.decode.end()
                       ? sample.members.erase(it)
                       : std::next(it);
          std::pair<shards::Sample, std::string> item{std::move(sample), file};
          if (options.shuffle_buffer <= 0) {
            if (!emit(std::move(item))) return;
          } else if (int64_t(buffer.size()) < options.shuffle_buffer) {
            buffer.push_back(std::move(item));
          } else {
            const size_t j = rng() % buffer.size();
            std::swap(buffer[j], item);
            if (!emit(std::move(item))) return;
          }
        }
      }
      while (!buffer.empty()) {
        const size_t j = rng() % buffer.size();
        std::swap(buffer[j], buffer.back());
        auto item = std::move(buffer.back());
        buffer.pop_back();
        if (!emit(std::move(item))) return;
      }
      if (index == 0) throw InvalidInput(options.dataset, "holds no samples for this rank", "generate data first");
    }
  }

  void decode() {
    for (;;) {
      Raw item;
      {
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock, [&] { return stop || !raw.empty(); });
        if (stop) return;
        item = std::move(raw.front());
        raw.pop_front();
      }
      Example example = decode_sample(item.sample.key, item.sample.members, item.source);
      if (options.augment.enabled)
        augment_example(example, options.augment,
                        mix({options.seed, uint64_t(item.epoch), uint64_t(options.rank), uint64_t(item.index), 1}));
      if (options.transform)
        options.transform(example,
                          mix({options.seed, uint64_t(item.epoch), uint64_t(options.rank), uint64_t(item.index), 2}));
      std::lock_guard<std::mutex> lock(mutex);
      done.emplace(item.sequence, Done{item.epoch, item.index, std::move(example)});
      changed.notify_all();
    }
  }

  Done take() {
    std::unique_lock<std::mutex> lock(mutex);
    changed.wait(lock, [&] { return error || done.count(next_sequence); });
    if (error) std::rethrow_exception(error);
    auto node = done.extract(next_sequence++);
    changed.notify_all();
    return std::move(node.mapped());
  }
};

void Augment::check() const {
  if (!(flip_probability >= 0 && flip_probability <= 1))
    throw InvalidInput("augmentation", "the flip probability must lie in [0, 1]", "use e.g. 0.5 (default)");
  if (!(shift_pixels >= 0) || !(rotate_degrees >= 0 && rotate_degrees <= 180) || !(scale >= 0 && scale < 1))
    throw InvalidInput("augmentation", "shift must be >= 0 px, rotation in [0, 180] degrees and scale in [0, 1)",
                       "use e.g. 10, 10 and 0.1 (default)");
}

void LoaderOptions::check() const {
  if (world < 1 || rank < 0 || rank >= world)
    throw InvalidInput("rank " + std::to_string(rank), "is outside world size " + std::to_string(world),
                       "check RANK and WORLD_SIZE");
  if (batch_size < 1) throw InvalidInput("--batch", "must be at least 1", "give a positive batch size");
  if (shuffle_buffer < 0) throw InvalidInput("the shuffle buffer", "must not be negative", "0 keeps the shards' order");
  if (decode_threads < 1 || decode_threads > 256)
    throw InvalidInput("decode threads", std::to_string(decode_threads) + " is outside [1, 256]", "use e.g. 2 (default)");
  augment.check();
}

ShardLoader::ShardLoader(LoaderOptions options) : options_(std::move(options)) {
  options_.check();
  const shards::Manifest manifest = shards::open_dataset(options_.dataset);
  for (size_t i = 0; i < manifest.shards.size(); ++i) {
    if (int(i % options_.world) != options_.rank) continue;
    shards_.push_back(shards::shard_path(options_.dataset, manifest.shards[i]));
    int64_t count = manifest.shards[i].samples;
    if (count < 0) {  // a bare .tar: count it
      shards::ShardReader reader(shards_.back());
      shards::Sample s;
      for (count = 0; reader.next(s);) ++count;
    }
    epoch_size_ += count;
  }
  if (shards_.empty())
    throw InvalidInput(options_.dataset, "has " + std::to_string(manifest.shards.size()) + " shard(s), fewer than the " +
                                             std::to_string(options_.world) + " ranks",
                       "write at least one shard per rank (texgen --samples-per-shard) or use fewer ranks");
  if (epoch_size_ == 0) throw InvalidInput(options_.dataset, "holds no samples for this rank", "generate data first");
  seek({0, 0});
}

ShardLoader::~ShardLoader() = default;

void ShardLoader::seek(const Cursor& cursor) {
  pipeline_.reset();
  cursor_ = cursor;
  if (cursor_.index >= epoch_size_) cursor_ = {cursor_.epoch + cursor_.index / epoch_size_, cursor_.index % epoch_size_};
  pipeline_ = std::make_unique<Pipeline>(options_, shards_, epoch_size_, cursor_);
}

Batch ShardLoader::next() {
  std::vector<Example> examples;
  for (int64_t i = 0; i < options_.batch_size; ++i) {
    auto item = pipeline_->take();
    examples.push_back(std::move(item.example));
    cursor_ = {item.epoch, item.index + 1};
    if (cursor_.index == epoch_size_) cursor_ = {cursor_.epoch + 1, 0};
  }
  return collate(examples);
}

Cursor ShardLoader::cursor() const { return cursor_; }
int64_t ShardLoader::epoch_size() const { return epoch_size_; }

}  // namespace bareskin::data
