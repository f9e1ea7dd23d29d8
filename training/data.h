// Training data: batches decoded from dataset shards (core/shards.h) with a shuffle buffer, background decode
// threads, augmentation, and a cursor that a checkpoint stores so a resumed run sees the same batches as an
// uninterrupted one. The order is a pure function of (seed, epoch, rank): shards are dealt to ranks by index
// (shard i goes to rank i % world), each rank shuffles its own shards, then samples through a seeded buffer.
#pragma once
#include <torch/types.h>

#include <nlohmann/json.hpp>

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace bareskin::data {

// A decoded sample. Members "<name>.png" become tensors[name] ([C,H,W] float in [0,1]); the "json" member is `meta`,
// and its "landmarks" array ([[x, y], ...], pixels, origin at the top-left corner of the image) becomes
// tensors["landmarks"] ([N,2] float). Other members are ignored.
struct Example {
  std::string key;
  std::map<std::string, torch::Tensor> tensors;
  nlohmann::json meta;
};

// Examples stacked along a new first dimension (every example must have the same members and sizes).
struct Batch {
  std::vector<std::string> keys;
  std::map<std::string, torch::Tensor> tensors;
  std::vector<nlohmann::json> meta;
  int64_t size() const { return int64_t(keys.size()); }
  const torch::Tensor& at(const std::string& name) const;  // InvalidInput naming the missing member
};
Batch collate(const std::vector<Example>& examples);

// Random similarity + flip, drawn per example (Deep3DFaceRecon's ranges by default when enabled): every image member
// is resampled through the same transform (bilinear; nearest for the members named in `nearest`) and the landmarks
// follow; a flip mirrors x and swaps left/right iBUG-68 landmarks.
struct Augment {
  bool enabled = false;
  double flip_probability = 0.5;
  double shift_pixels = 10;    // uniform in [-10, 10] on each axis, at the image's size
  double scale = 0.1;          // uniform factor in [0.9, 1.1]
  double rotate_degrees = 10;  // uniform in [-10, 10]
  std::vector<std::string> nearest = {"skin", "mask"};  // label/mask members
  void check() const;  // InvalidInput for a probability outside [0, 1] or a negative range
};
// Applies one draw of `augment` to an example (exposed for tests and for tasks that augment on their own).
void augment_example(Example& example, const Augment& augment, uint64_t seed);
// The iBUG-68 index of each landmark's mirror image (0 <-> 16, 36 <-> 45, ...).
const std::vector<int64_t>& ibug68_mirror();

struct LoaderOptions {
  std::string dataset;                // folder with manifest.json, or one .tar shard
  std::vector<std::string> required;  // member suffixes every sample must have, e.g. {"makeup.png", "json"}
  // Member suffixes decoded (empty: all); the others are dropped undecoded as they are read, so a task that uses one
  // map of samples carrying many (an upscaler on 4K texture samples) neither decodes nor holds the rest.
  std::vector<std::string> decode;
  int64_t batch_size = 4;
  uint64_t seed = 0;
  int rank = 0, world = 1;
  int64_t shuffle_buffer = 256;  // 0: the shards' own order (evaluation)
  int decode_threads = 2;
  Augment augment;
  // A task's own per-example augmentation, applied after `augment` on the decode threads. Its seed is a pure function
  // of (seed, epoch, rank, the example's index), so a resumed run draws what an uninterrupted one would.
  std::function<void(Example&, uint64_t seed)> transform;
  void check() const;  // InvalidInput naming the flag (and augment.check())
};

// Where a loader stands: the epoch and the examples already handed out in it.
struct Cursor {
  int64_t epoch = 0;
  int64_t index = 0;
};
nlohmann::json to_json(const Cursor& cursor);
Cursor cursor_from_json(const nlohmann::json& j);

// Anything the Trainer can draw batches from.
class DataSource {
 public:
  virtual ~DataSource() = default;
  virtual Batch next() = 0;
  virtual Cursor cursor() const = 0;
  virtual void seek(const Cursor& cursor) = 0;
  virtual int64_t epoch_size() const = 0;  // examples per epoch (this rank)
};

// Endless stream of batches over epochs. Decoding runs ahead in `decode_threads` threads; the order of examples does
// not depend on the thread count. InvalidInput for an empty dataset, a rank with no shards, a sample missing a
// required member or a corrupt image (naming the shard and sample).
class ShardLoader : public DataSource {
 public:
  explicit ShardLoader(LoaderOptions options);
  ~ShardLoader() override;
  Batch next() override;
  Cursor cursor() const override;
  void seek(const Cursor& cursor) override;
  int64_t epoch_size() const override;

 private:
  struct Pipeline;
  LoaderOptions options_;
  std::vector<std::string> shards_;  // this rank's shards
  int64_t epoch_size_ = 0;
  Cursor cursor_;
  std::unique_ptr<Pipeline> pipeline_;
};

// Decodes one raw sample (exposed for tools that read shards without training).
Example decode_sample(const std::string& key, const std::map<std::string, std::string>& members,
                      const std::string& source);

}  // namespace bareskin::data
