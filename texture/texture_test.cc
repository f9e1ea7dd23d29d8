// Texture inference: occlusion masks and the pix2pixHD task on tiny procedural UV maps, and loading a trained run.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>

#include "core/error.h"
#include "core/files.h"
#include "core/png.h"
#include "core/test_options.h"
#include "core/test_util.h"
#include "core/shards.h"
#include "texture/pix2pixhd.h"
#include "texture/uvnet.h"
#include "training/optimizer.h"
#include "training/ssim.h"

namespace bareskin::texture {
namespace {
namespace fs = std::filesystem;

// A procedural texture sample at res²: a skin-like diffuse field (low + high frequencies), its normal, roughness and
// specular derived from the same fields, and the inputs a dataset holds: the diffuse seen through a visibility
// region (unwrap, confidence), a blurred albedo (3DMM appearance), a smooth normal and position.
std::map<std::string, torch::Tensor> procedural_sample(int64_t j, int64_t res) {
  auto gen = at::detail::createCPUGenerator(uint64_t(j) + 77);
  auto lin = torch::linspace(0, 1, res);
  auto v = lin.view({1, res, 1}).expand({1, res, res});
  auto u = lin.view({1, 1, res}).expand({1, res, res});
  auto phase = torch::rand({4}, gen);
  auto low = 0.5 + 0.2 * torch::sin(6.0 * u + 6 * phase[0]) * torch::cos(5.0 * v + 6 * phase[1]);
  auto high = 0.08 * torch::sin(40.0 * u + 6 * phase[2]) * torch::sin(37.0 * v + 6 * phase[3]);
  auto tint = torch::tensor({0.85f, 0.62f, 0.5f}).view({3, 1, 1});
  auto diffuse = (tint * (low + high)).clamp(0, 1);
  auto nx = 0.5 + 2.0 * high, ny = 0.5 + 2.0 * high.roll(3, 2);
  auto normal = torch::cat({nx, ny, torch::ones_like(nx) * 0.9}, 0).clamp(0, 1);
  auto roughness = (0.3 + high * 2 + 0.2 * v).clamp(0, 1);
  auto specular = (0.4 - high + 0.1 * u).clamp(0, 1);
  auto seen = (((u - 0.5).pow(2) + (v - 0.5).pow(2)) < 0.16).to(torch::kFloat32);
  std::map<std::string, torch::Tensor> s;
  s["unwrap"] = diffuse * seen;
  s["confidence"] = seen * (1 - 2 * (u - 0.5).abs());
  s["mm_albedo"] = tint * low;
  s["mm_normal"] = torch::cat({u, v, torch::ones_like(u) * 0.8}, 0);
  s["mm_position"] = torch::cat({u, v, 0.5 + 0.3 * torch::sin(3.0 * u)}, 0);
  s["diffuse"] = diffuse;
  s["normal"] = normal;
  s["roughness"] = roughness;
  s["specular"] = specular;
  return s;
}

data::Batch procedural_batch(int64_t first, int64_t count, int64_t res) {
  std::vector<data::Example> examples;
  for (int64_t j = first; j < first + count; ++j) {
    data::Example e;
    e.key = std::to_string(j);
    e.tensors = procedural_sample(j, res);
    examples.push_back(e);
  }
  return data::collate(examples);
}

Image to_image(const torch::Tensor& chw) {
  auto hwc = chw.permute({1, 2, 0}).contiguous();
  Image image(int(hwc.size(1)), int(hwc.size(0)), int(hwc.size(2)), ColorSpace::Data);
  std::memcpy(image.pixels.data(), hwc.data_ptr<float>(), image.pixels.size() * 4);
  return image;
}

// A shard set of procedural texture samples (PNG members as texgen make-dataset writes them) with `hr` maps ×4.
void write_texture_shards(const std::string& dir, int64_t first, int64_t count, int64_t res, bool hr) {
  fs::create_directories(dir);
  shards::ShardWriter writer(dir, "texture", 4);
  for (int64_t j = first; j < first + count; ++j) {
    shards::Sample sample;
    sample.key = fmt::format("{:08d}", j);
    for (auto& [name, t] : procedural_sample(j, res))
      sample.members[name + ".png"] = encode_png(to_image(t), name == "mm_position" ? 16 : 8);
    if (hr)
      for (auto& [name, t] : procedural_sample(j, res * 4))
        if (name == "diffuse") sample.members[name + "_hr.png"] = encode_png(to_image(t), 8);
    sample.members["json"] = nlohmann::json({{"subject", "mm/" + std::to_string(j)}}).dump();
    writer.write(sample);
  }
  shards::Manifest manifest;
  manifest.shards = writer.finish();
  shards::write_manifest(dir, manifest);
}

TextureNetOptions tiny_texture_options(int64_t res) {
  TextureNetOptions o;
  o.res = res;
  o.generator_options = {{"ngf", 8}, {"n_downsampling", 2}, {"n_blocks", 2}};
  o.discriminator_options = {{"ndf", 8}, {"n_layers", 2}, {"num_D", 2}};
  return o;
}

TEST(Pix2PixHD, OptionsRoundTripAndRefuseUnknownKeys) {
  testing::expect_options_json<TextureNetOptions>({{"generator", "local"},
                                                   {"generator_options", {{"ngf", 8}}},
                                                   {"discriminator_options", {{"num_D", 3}}},
                                                   {"res", 512},
                                                   {"lambda_feat", 5.0},
                                                   {"lambda_perceptual", 0.0},
                                                   {"lambda_l1", 1.0},
                                                   {"lr", 1e-3},
                                                   {"beta1", 0.9},
                                                   {"beta2", 0.99},
                                                   {"lr_decay", 0.25},
                                                   {"clip_grad_norm", 2.0},
                                                   {"steps", 200}});
  EXPECT_THROW(nlohmann::json({{"generator", "huge"}}).get<TextureNetOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"res", 8}}).get<TextureNetOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"lr_decay", 1.5}}).get<TextureNetOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"clip_grad_norm", -1.0}}).get<TextureNetOptions>(), InvalidInput);
  // Runs from before clip_grad_norm read with it off.
  EXPECT_EQ(nlohmann::json({{"lr", 1e-3}}).get<TextureNetOptions>().clip_grad_norm, 0.0);
  // Runs from before lr_decay stored the decay's first step (-1: half the run); they read as the same schedule.
  auto legacy = [](const nlohmann::json& j) { return j.get<TextureNetOptions>(); };
  EXPECT_DOUBLE_EQ(legacy({{"decay_start", 50}, {"steps", 200}}).lr_decay, 0.25);
  EXPECT_DOUBLE_EQ(legacy({{"decay_start", -1}, {"steps", 301}}).lr_decay, 0.5);  // the default then and now
  const auto old = legacy({{"decay_start", 120}, {"steps", 301}});
  EXPECT_EQ(train::Schedule::linear_from(old.lr_decay, old.steps).decay_start, 120);  // the same step as before
  EXPECT_THROW(legacy({{"decay_start", 50}, {"lr_decay", 0.5}}), InvalidInput);
  EXPECT_THROW(legacy({{"decay_start", "half"}}), InvalidInput);
}

TEST(Occlusion, MaskMultipliesTheUnwrapAndItsConfidenceOnly) {
  auto batch = procedural_batch(0, 2, 32);
  torch::manual_seed(3);
  auto mask = OcclusionSampler().sample(2, 32);
  ASSERT_EQ(mask.sizes(), (std::vector<int64_t>{2, 1, 32, 32}));
  // Synthetic masks are binary and cut something out of every sample, but not everything.
  EXPECT_TRUE(((mask == 0) | (mask == 1)).all().item<bool>());
  for (int b = 0; b < 2; ++b) {
    const double visible = mask[b].mean().item<double>();
    EXPECT_GT(visible, 0.05);
    EXPECT_LT(visible, 0.999);
  }
  Pix2PixHDTask task(tiny_texture_options(32), OcclusionSampler());
  auto clean = (task.input(batch) + 1) / 2;
  auto occluded = (task.input(batch, mask) + 1) / 2;
  // Channels 0–3 (unwrap RGB, confidence) are the clean ones times the mask; 4–12 (3DMM) untouched.
  EXPECT_TRUE(torch::allclose(occluded.slice(1, 0, 4), clean.slice(1, 0, 4) * mask, 1e-6, 1e-6));
  EXPECT_TRUE(torch::equal(occluded.slice(1, 4), clean.slice(1, 4)));
  EXPECT_GT((occluded.slice(1, 0, 4) - clean.slice(1, 0, 4)).abs().sum().item<double>(), 1.0);
}

TEST(Occlusion, MasksFromAShardSetAreTheStoredPixels) {
  const auto dir = testing::temp_dir();
  shards::ShardWriter writer(dir, "mask", 8);
  std::vector<Image> masks;
  for (int i = 0; i < 3; ++i) {
    Image m(16, 16, 1, ColorSpace::Data);
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) m.at(x, y) = (x + i * y) % 5 == 0 ? 0.f : 1.f;
    masks.push_back(m);
    writer.write({fmt::format("{:08d}", i), {{"mask.png", encode_png(m)}, {"json", "{\"source\":\"test\"}"}}});
  }
  shards::Manifest manifest;
  manifest.shards = writer.finish();
  shards::write_manifest(dir, manifest);
  auto sampler = OcclusionSampler::from_shards(dir, 16);
  ASSERT_EQ(sampler.count(), 3);
  torch::manual_seed(1);
  auto drawn = sampler.sample(6, 16);
  // Every drawn mask is one of the stored ones, possibly mirrored.
  for (int b = 0; b < 6; ++b) {
    bool found = false;
    for (const auto& m : masks) {
      auto t = torch::from_blob(const_cast<float*>(m.pixels.data()), {1, 16, 16}).clone();
      found = found || torch::equal(drawn[b], t) || torch::equal(drawn[b], t.flip({2}));
    }
    EXPECT_TRUE(found) << "draw " << b;
  }
  fs::remove_all(dir);
}

TEST(Pix2PixHD, TheGeneratorLearnsAFixedBatch) {
  torch::manual_seed(0);
  auto o = tiny_texture_options(32);
  o.lambda_perceptual = 1;  // the VGG term is on, at a weight that keeps this test in seconds
  Pix2PixHDTask task(o, OcclusionSampler());
  auto batch = procedural_batch(0, 2, 32);
  std::vector<std::unique_ptr<torch::optim::Adam>> optimizers;
  for (auto& spec : task.optimizers())
    optimizers.push_back(std::make_unique<torch::optim::Adam>(
        spec.groups[0].params, torch::optim::AdamOptions(spec.groups[0].lr).betas({spec.beta1, spec.beta2})));
  auto eval = [&] {
    torch::NoGradGuard no_grad;
    auto e = task.evaluate(batch);
    return (e["psnr_diffuse"] + e["psnr_normal"] + e["psnr_roughness"] + e["psnr_specular"]) / 4;
  };
  const double before = eval();
  double first_feat = 0, last_feat = 0;
  for (int step = 0; step < 60; ++step)
    for (size_t p = 0; p < optimizers.size(); ++p) {
      optimizers[p]->zero_grad();
      auto losses = task.loss(p, batch);
      torch::Tensor total = torch::zeros({});
      for (auto& [name, value] : losses) {
        ASSERT_TRUE(std::isfinite(value.item<double>())) << name;
        total = total + value;
      }
      if (p == 0 && step < 5) first_feat += losses["feat"].item<double>() / 5;
      if (p == 0 && step >= 55) last_feat += losses["feat"].item<double>() / 5;
      total.backward();
      optimizers[p]->step();
    }
  const double after = eval();
  EXPECT_LT(last_feat, 0.7 * first_feat);
  EXPECT_GT(after, before + 3) << "mean PSNR over the four maps, dB";
}

TEST(UVNet, StartsAtTheUnwrapOverTheModelsMaps) {
  // Untrained, the UV net's maps are its base: the unwrap where seen, the 3DMM albedo elsewhere, the flat normal,
  // mid-grey roughness and specular. The 3DMM-only baseline differs from it where the unwrap was seen.
  torch::manual_seed(0);
  auto o = tiny_texture_options(32);
  o.generator = "uv";
  o.generator_options = {{"ngf", 4}, {"num_downs", 5}};
  Pix2PixHDTask task(o, OcclusionSampler());
  auto batch = procedural_batch(0, 2, 32);
  auto x = task.input(batch);
  torch::NoGradGuard no_grad;
  auto y = run_generator(task.generator(), x);
  auto seen = (x.narrow(1, 3, 1) > -1).expand({-1, 3, -1, -1});
  auto diffuse = torch::where(seen, x.narrow(1, 0, 3), x.narrow(1, 4, 3));
  EXPECT_TRUE(torch::equal(y.narrow(1, 0, 3), diffuse));
  EXPECT_TRUE(torch::equal(y.narrow(1, 3, 3), torch::tensor({0.f, 0.f, 1.f}).view({1, 3, 1, 1}).expand_as(diffuse)));
  EXPECT_TRUE(torch::equal(y.narrow(1, 6, 2), torch::zeros_like(y.narrow(1, 6, 2))));
  auto truth = (task.target(batch) + 1) * 0.5;
  auto layout = torch::ones_like(truth.narrow(1, 0, 1));
  auto mm = mm_only_maps(x, truth, layout);
  EXPECT_TRUE(torch::allclose(mm.narrow(1, 0, 3), (x.narrow(1, 4, 3) + 1) * 0.5));
  EXPECT_TRUE(torch::allclose(mm.narrow(1, 6, 1).mean({2, 3}), truth.narrow(1, 6, 1).mean({2, 3})));
  // Masked PSNR: only the masked texels count.
  auto a = torch::zeros({1, 1, 4, 4}), c = torch::zeros({1, 1, 4, 4}), half = torch::zeros({1, 1, 4, 4});
  c.narrow(3, 2, 2).fill_(1);
  half.narrow(3, 0, 2).fill_(1);
  c[0][0][0][0] = 0.1;
  EXPECT_NEAR(losses::psnr(a, c, half).item<double>(), 10 * std::log10(8 / 0.01), 1e-4);
  auto e = task.evaluate(batch);
  for (const char* m : {"diffuse", "normal", "roughness", "specular"}) EXPECT_TRUE(e.count(std::string("psnr_mm_") + m));
  o.generator_options = {{"ngf", 4}, {"num_downs", 6}};
  EXPECT_THROW(Pix2PixHDTask(o, OcclusionSampler()), InvalidInput) << "32 is not a multiple of 2^6";
  o.generator_options = {{"ngf", 4}, {"num_downs", 5}, {"fill", "mean"}};
  EXPECT_THROW(Pix2PixHDTask(o, OcclusionSampler()), InvalidInput) << "fill is albedo or matched";
}

TEST(UVNet, MatchedFillCarriesTheUnwrapsLevelPerChannel) {
  // Where the photo saw the face, the unwrap is the albedo at 0.5, 1 and 1.5 × per channel (one sample), and 0.8 ×
  // (the other): the matched fill is the albedo at those gains where the photo did not see, the unwrap where it did.
  torch::manual_seed(0);
  const int64_t n = 16;
  auto albedo01 = torch::rand({2, 3, n, n}) * 0.4 + 0.2;  // × 1.5 stays below 1
  auto gains = torch::tensor({0.5f, 1.0f, 1.5f, 0.8f, 0.8f, 0.8f}).view({2, 3, 1, 1});
  auto seen = (torch::rand({2, 1, n, n}) > 0.4).to(torch::kFloat);
  auto inputs = torch::zeros({2, 13, n, n});
  inputs.narrow(1, 0, 3).copy_(seen * (albedo01 * gains * 2 - 1) - (1 - seen));
  inputs.narrow(1, 3, 1).copy_(seen * 2 - 1);
  inputs.narrow(1, 4, 3).copy_(albedo01 * 2 - 1);
  auto expected = seen * inputs.narrow(1, 0, 3) + (1 - seen) * (albedo01 * gains * 2 - 1);
  EXPECT_TRUE(torch::allclose(uv_base(inputs, UVFill::matched).narrow(1, 0, 3), expected, 1e-5, 1e-5));
  auto plain = seen * inputs.narrow(1, 0, 3) + (1 - seen) * inputs.narrow(1, 4, 3);
  EXPECT_TRUE(torch::equal(uv_base(inputs).narrow(1, 0, 3), plain)) << "the default fill is the albedo as it is";
  // Nothing seen: the albedo as it is.
  inputs.narrow(1, 3, 1).fill_(-1);
  EXPECT_TRUE(torch::equal(uv_base(inputs, UVFill::matched).narrow(1, 0, 3), inputs.narrow(1, 4, 3)));
}

TEST(Pix2PixHD, TrainsFromShardsAndLoadsForInference) {
  const auto dir = testing::temp_dir();
  write_texture_shards(dir + "/train", 0, 4, 32, false);
  write_texture_shards(dir + "/val", 100, 2, 48, false);  // another size: resized to the net's
  {
    // The loader hands back what was written, grey members included (8-bit quantisation apart).
    data::LoaderOptions lo;
    lo.dataset = dir + "/train";
    lo.batch_size = 4;
    lo.shuffle_buffer = 0;
    data::ShardLoader loader(lo);
    auto batch = loader.next();
    for (int64_t b = 0; b < 4; ++b) {
      auto truth = procedural_sample(std::stoll(batch.keys[b]), 32);
      for (const char* name : {"confidence", "roughness", "diffuse"})
        EXPECT_LT((batch.at(name)[b] - truth[name]).abs().max().item<double>(), 0.6 / 255) << name;
    }
  }
  TrainRunOptions run;
  run.data = dir + "/train";
  run.val = dir + "/val";
  run.output = dir + "/run";
  run.steps = 3;
  run.batch = 2;
  run.log_every = run.eval_every = run.sample_every = run.checkpoint_every = 3;
  run.progress = false;
  auto o = tiny_texture_options(32);
  o.lambda_perceptual = 0;
  auto result = train_texture(run, o);
  EXPECT_EQ(result.steps, 3);
  EXPECT_TRUE(result.last_eval.count("psnr_diffuse"));
  EXPECT_TRUE(fs::exists(run.output + "/samples/step_0000003.png"));

  auto net = TextureNet::load(run.output, torch::kCPU);
  auto inputs = procedural_sample(7, 64);  // larger inputs are resized to the run's 32²
  auto maps = net.infer(inputs);
  for (const auto& m : output_maps()) {
    ASSERT_EQ(maps[m.name].sizes(), (std::vector<int64_t>{1, m.channels, 32, 32})) << m.name;
    EXPECT_GE(maps[m.name].min().item<double>(), 0);
    EXPECT_LE(maps[m.name].max().item<double>(), 1);
  }
  auto n = maps["normal"] * 2 - 1;
  EXPECT_TRUE(torch::allclose(n.norm(2, 1), torch::ones({1, 32, 32}), 1e-4, 1e-4));
  // An input missing a member is named. (That a texture run is not an upscaler belongs to upscale/, above texture/.)
  inputs.erase("mm_normal");
  try {
    net.infer(inputs);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("mm_normal"), std::string::npos);
  }
  fs::remove_all(dir);
}
}  // namespace
}  // namespace bareskin::texture
