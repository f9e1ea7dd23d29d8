// SRGAN ×4: the bicubic base, the patch source, learning on block maps and tiled inference.
#include <gtest/gtest.h>

#include <ATen/Parallel.h>

#include <filesystem>

#include "core/error.h"
#include "core/test_options.h"
#include "core/test_util.h"
#include "upscale/srgan.h"
#include "training/ssim.h"

namespace bareskin::texture {
namespace {
namespace fs = std::filesystem;

// A case SRGAN can learn and bicubic cannot: maps made of constant 4×4 blocks on the ×4 grid, whose box-filtered
// low-resolution version holds the block values exactly, so the ideal upscaler is a sharp replication while bicubic
// blurs every block edge.
torch::Tensor block_maps(int64_t n, int64_t side, uint64_t seed) {
  auto gen = at::detail::createCPUGenerator(seed);
  auto blocks = torch::rand({n, 3, side / 4, side / 4}, gen);
  return blocks.repeat_interleave(4, 2).repeat_interleave(4, 3);
}

TEST(Srgan, BicubicBaseIsTorchBicubicAndOldRunsKeepBilinear) {
  // The untrained net (conv_last starts at zero) is exactly its base: the bicubic upsampling (align_corners false).
  torch::manual_seed(3);
  UpscaleOptions o;
  o.generator_options = {{"num_feat", 4}, {"num_block", 1}};
  auto G = make_upscaler(o);
  auto lr = torch::rand({1, 3, 8, 8});
  torch::NoGradGuard no_grad;
  auto expected = torch::nn::functional::interpolate(
      lr, torch::nn::functional::InterpolateFuncOptions().scale_factor(std::vector<double>{4, 4}).mode(torch::kBicubic)
              .align_corners(false));
  EXPECT_LT((G->forward(lr) - expected).abs().max().item<double>(), 1e-6);
  // A run's configuration without the keys (runs before them) reads as BasicSR's: bilinear base, L1; options
  // without them otherwise take the struct's defaults.
  nlohmann::json j = o;
  j.erase("base");
  j.erase("pixel_loss");
  const auto old = upscale_options_of_run(j);
  EXPECT_EQ(old.base, "bilinear");
  EXPECT_EQ(old.pixel_loss, "l1");
  EXPECT_EQ(j.get<UpscaleOptions>().base, "bicubic");
  EXPECT_EQ(j.get<UpscaleOptions>().pixel_loss, "mse");
  EXPECT_EQ(upscale_options_of_run(nlohmann::json(o)).base, "bicubic");
  j["base"] = "nearest";
  EXPECT_THROW(j.get<UpscaleOptions>(), InvalidInput);
  EXPECT_THROW(upscale_options_of_run(j), InvalidInput);
}

TEST(Srgan, OptionsRoundTripAndRefuseUnknownKeys) {
  testing::expect_options_json<UpscaleOptions>({{"map", "normal"},
                                                {"phase", "l1"},
                                                {"pixel_loss", "l1"},
                                                {"base", "bilinear"},
                                                {"generator_options", {{"num_feat", 8}}},
                                                {"discriminator_options", {{"num_feat", 8}}},
                                                {"patch", 256},
                                                {"lambda_l1", 1.0},
                                                {"lambda_perceptual", 0.0},
                                                {"lambda_gan", 0.01},
                                                {"lr", 2e-4},
                                                {"beta1", 0.5},
                                                {"beta2", 0.99},
                                                {"lr_decay", 0.5},
                                                {"clip_grad_norm", 10.0}});
  EXPECT_THROW(nlohmann::json({{"patch", 64}}).get<UpscaleOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"clip_grad_norm", -1.0}}).get<UpscaleOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"map", "albedo"}}).get<UpscaleOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"lr_decay", 1.5}}).get<UpscaleOptions>(), InvalidInput);
  // A constant rate and no clip (the defaults) are not written: the config of a run from before they existed reads
  // the same.
  EXPECT_FALSE(nlohmann::json(UpscaleOptions{}).contains("lr_decay"));
  EXPECT_FALSE(nlohmann::json(UpscaleOptions{}).contains("clip_grad_norm"));
}

TEST(Srgan, LrDecayPlacesTheLinearDecayInTheRun) {
  UpscaleOptions o;
  o.phase = "gan";
  o.lambda_perceptual = 0;
  o.generator_options = {{"num_feat", 4}, {"num_block", 1}};
  o.discriminator_options = {{"num_feat", 4}};
  for (const auto& spec : SrganTask(o, 400).optimizers()) EXPECT_EQ(spec.schedule.kind, "constant");
  o.lr_decay = 0.25;
  const auto specs = SrganTask(o, 400).optimizers();
  ASSERT_EQ(specs.size(), 2u);  // G and D decay alike
  for (const auto& spec : specs) {
    EXPECT_EQ(spec.schedule.kind, "linear");
    EXPECT_EQ(spec.schedule.decay_start, 100);
    EXPECT_DOUBLE_EQ(spec.schedule.factor(250, 400), 0.5);
  }
}

// A data source of fixed maps (sample k: every texel = k + its index / 1e6), one per batch, counting reads.
class CountingSource : public data::DataSource {
 public:
  data::Batch next() override {
    data::Batch b;
    const int64_t k = reads++;
    b.keys = {"s" + std::to_string(k)};
    b.meta = {nlohmann::json::object()};
    b.tensors["diffuse_hr"] = (k + torch::arange(3 * 32 * 32, torch::kFloat).reshape({1, 3, 32, 32}) / 1e6);
    b.tensors["diffuse"] = torch::zeros({1, 3, 8, 8});
    return b;
  }
  data::Cursor cursor() const override { return {0, reads}; }
  void seek(const data::Cursor& c) override { reads = c.index; }
  int64_t epoch_size() const override { return 100; }
  int64_t reads = 0;
};

TEST(Srgan, PatchSourceCropsPooledMapsOnTheGridAndRefreshesThePool) {
  torch::manual_seed(4);
  auto counting = std::make_unique<CountingSource>();
  CountingSource* source = counting.get();
  PatchSource patches(std::move(counting), "diffuse", 16, 3, /*pool=*/2, /*crops_per_map=*/4);
  std::set<std::string> seen;
  for (int step = 0; step < 8; ++step) {
    const data::Batch b = patches.next();
    ASSERT_EQ(b.size(), 3);
    const auto& crops = b.at("diffuse_hr");
    ASSERT_EQ(crops.sizes(), (std::vector<int64_t>{3, 3, 16, 16}));
    for (int64_t i = 0; i < 3; ++i) {
      // "<sample>@<y>,<x>": the crop is that sample's map at that place, on the 4-texel grid.
      const std::string& key = b.keys[i];
      const auto at = key.find('@'), comma = key.find(',');
      const int64_t k = std::stoll(key.substr(1, at - 1)), y = std::stoll(key.substr(at + 1, comma - at - 1)),
                    x = std::stoll(key.substr(comma + 1));
      EXPECT_EQ(y % 4, 0);
      EXPECT_EQ(x % 4, 0);
      auto truth = (k + torch::arange(3 * 32 * 32, torch::kFloat).reshape({3, 32, 32}) / 1e6)
                       .slice(1, y, y + 16).slice(2, x, x + 16);
      EXPECT_TRUE(torch::equal(crops[i], truth)) << key;
      seen.insert(key.substr(0, at));
    }
  }
  // 24 crops: the pool of 2 filled once, then one new map per 4 crops drawn (before the 5th, 9th, ..., 21st crop
  // the oldest is replaced): 2 + 5 reads.
  EXPECT_EQ(source->reads, 7);
  EXPECT_GE(seen.size(), 4u);
  // The member and its size are checked.
  PatchSource too_big(std::make_unique<CountingSource>(), "diffuse", 64, 1);
  EXPECT_THROW(too_big.next(), InvalidInput);
}

TEST(Srgan, BeatsBicubicOnBlockMapsAndTheGanPhaseReachesBothNets) {
  torch::manual_seed(0);
  UpscaleOptions o;
  o.phase = "l1";
  o.generator_options = {{"num_feat", 16}, {"num_block", 2}};
  SrganTask task(o, 150);
  auto& G = task.generator();
  torch::optim::Adam adam(G->parameters(), torch::optim::AdamOptions(1e-3));
  for (int step = 0; step < 150; ++step) {
    data::Batch batch;
    batch.keys = {std::to_string(step)};
    batch.tensors["diffuse_hr"] = block_maps(2, 128, step);
    batch.keys.push_back("b");
    adam.zero_grad();
    auto losses = task.loss(0, batch);
    ASSERT_EQ(losses.size(), 1u);
    losses.at("mse").backward();  // the pre-training default: SRGAN's MSE
    adam.step();
  }
  auto hr = block_maps(2, 128, 999);  // held out
  auto lr = torch::nn::functional::avg_pool2d(hr, torch::nn::functional::AvgPool2dFuncOptions(4));
  const double srgan = losses::psnr(upscale_x4(*G, lr, "diffuse", 16), hr).mean().item<double>();
  const double bicubic = losses::psnr(bicubic_x4(lr, "diffuse"), hr).mean().item<double>();
  EXPECT_GT(srgan, bicubic + 1) << "SRGAN " << srgan << " dB, bicubic " << bicubic << " dB";

  // GAN phase: one step of each phase gives every parameter of G and D a gradient.
  UpscaleOptions g = o;
  g.phase = "gan";
  SrganTask gan(g, 1);
  {  // from the pre-trained G, as --init does (the untrained G's zero conv_last passes no gradient upstream)
    torch::NoGradGuard no_grad;
    auto trained = G->named_parameters();
    for (auto& p : gan.generator()->named_parameters()) p.value().copy_(trained[p.key()]);
  }
  data::Batch batch;
  batch.keys = {"a", "b"};
  batch.tensors["diffuse_hr"] = block_maps(2, 128, 5);
  auto check_grads = [](torch::nn::Module& m, const char* name) {
    for (const auto& p : m.named_parameters()) {
      ASSERT_TRUE(p.value().grad().defined()) << name << " " << p.key();
      EXPECT_GT(p.value().grad().abs().sum().item<double>(), 0) << name << " " << p.key();
    }
  };
  auto modules = gan.modules();
  for (size_t phase = 0; phase < 2; ++phase) {
    for (auto& [name, m] : modules) m->zero_grad();
    auto losses = gan.loss(phase, batch);
    torch::Tensor total = torch::zeros({});
    for (auto& [name, v] : losses) total = total + v;
    total.backward();
    check_grads(*modules[phase == 0 ? "G" : "D"], phase == 0 ? "G" : "D");
  }
  EXPECT_EQ(gan.loss(0, batch).count("gan"), 1u);
}

TEST(Srgan, TiledInferenceIsTheWholeForward) {
  // upscale_x4 runs the trunk once and the x4 tail in tiles with a margin: every tile size gives the untiled net's
  // output (the truth here), for both bases and a map size that no tile divides.
  torch::manual_seed(3);
  for (const char* base : {"bicubic", "bilinear"}) {
    nets::MSRResNetOptions o;
    o.num_feat = 8;
    o.num_block = 2;
    o.base = base;
    nets::MSRResNet net(o);
    {
      torch::NoGradGuard no_grad;
      for (auto& p : net->named_parameters())
        if (p.key().rfind("conv_last", 0) == 0) p.value().normal_(0, 0.05);  // the bicubic base starts it at zero
    }
    const auto x = torch::rand({1, 3, 37, 45});
    torch::Tensor whole;
    {
      torch::NoGradGuard no_grad;
      whole = net->forward(x).clamp(0, 1);
    }
    ASSERT_GT((whole - bicubic_x4(x, "diffuse")).abs().max().item<double>(), 1e-3);  // the tail does something
    for (int64_t tile : {5, 16, 64})
      EXPECT_LT((upscale_x4(*net, x, "diffuse", tile) - whole).abs().max().item<double>(), 1e-5)
          << base << ", tile " << tile;
    // The tiles run in parallel, each whole on one thread: the same bits on every call and with one thread.
    const auto parallel = upscale_x4(*net, x, "diffuse", 5);
    EXPECT_TRUE(torch::equal(parallel, upscale_x4(*net, x, "diffuse", 5))) << base;
    const int threads = at::get_num_threads();
    at::set_num_threads(1);
    const auto serial = upscale_x4(*net, x, "diffuse", 5);
    at::set_num_threads(threads);
    EXPECT_TRUE(torch::equal(parallel, serial)) << base;
  }
}
}  // namespace
}  // namespace bareskin::texture
