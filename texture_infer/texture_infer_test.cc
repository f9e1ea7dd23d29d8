// Texture inference: occlusion masks, pix2pixHD and SRGAN tasks on tiny procedural UV maps, loading trained runs,
// the glTF writer against an independent Python reader.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>

#include "core/error.h"
#include "core/files.h"
#include "core/png.h"
#include "core/test_util.h"
#include "texgen/shards.h"
#include "texture_infer/glb.h"
#include "texture_infer/tasks.h"
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
  // A texture run is not an upscaler; an input missing a member is named.
  EXPECT_THROW(Upscaler::load(run.output, torch::kCPU), InvalidInput);
  inputs.erase("mm_normal");
  try {
    net.infer(inputs);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("mm_normal"), std::string::npos);
  }
  fs::remove_all(dir);
}

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
  // A configuration without the keys (runs before them) reads as BasicSR's: bilinear base, L1.
  nlohmann::json j = o;
  j.erase("base");
  j.erase("pixel_loss");
  const auto old = j.get<UpscaleOptions>();
  EXPECT_EQ(old.base, "bilinear");
  EXPECT_EQ(old.pixel_loss, "l1");
  j["base"] = "nearest";
  EXPECT_THROW(j.get<UpscaleOptions>(), InvalidInput);
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
  SrganTask task(o);
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
  SrganTask gan(g);
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

TEST(Glb, AnIndependentReaderFindsTheMeshAndMaterial) {
  // A 10 mm square whose vertex 0 has two UVs (a seam): 5 glTF vertices, 2 triangles.
  Mesh mesh;
  mesh.V.resize(4, 3);
  mesh.V << 0, 0, 0, 10, 0, 0, 10, 10, 0, 0, 10, 0;
  mesh.F.resize(2, 3);
  mesh.F << 0, 1, 2, 0, 2, 3;
  mesh.UV.resize(5, 2);
  mesh.UV << 0, 0, 1, 0, 1, 1, 0.25, 0.25, 0, 1;
  mesh.FUV.resize(2, 3);
  mesh.FUV << 0, 1, 2, 3, 2, 4;
  PbrMaps maps;
  maps.diffuse = Image(8, 8, 3, ColorSpace::Linear, 0.5f);
  maps.normal = Image(8, 8, 3, ColorSpace::Data, 0.5f);
  maps.roughness = Image(8, 8, 1, ColorSpace::Data, 0.4f);
  maps.specular = Image(8, 8, 1, ColorSpace::Data, 0.3f);
  const auto dir = testing::temp_dir();
  write_glb(dir + "/a.glb", mesh, maps);
  const std::string command = std::string("/usr/bin/python3 ") + BARESKIN_GLB_ORACLE + " " + dir + "/a.glb";
  FILE* pipe = popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buffer[4096];
  while (size_t n = fread(buffer, 1, sizeof(buffer), pipe)) out.append(buffer, n);
  ASSERT_EQ(pclose(pipe), 0) << "the oracle rejected the file: " << out;
  auto j = nlohmann::json::parse(out);
  EXPECT_EQ(j["vertices"], 5);
  EXPECT_EQ(j["triangles"], 2);
  EXPECT_NEAR(j["position_max"][0].get<double>(), 0.01, 1e-7);  // metres
  EXPECT_NEAR(j["position_max"][1].get<double>(), 0.01, 1e-7);
  EXPECT_NEAR(j["uv_min"][1].get<double>(), 0, 1e-7);  // v flipped to glTF's top-left origin
  EXPECT_NEAR(j["uv_max"][1].get<double>(), 1, 1e-7);
  EXPECT_EQ(j["base_color"], "diffuse");
  EXPECT_EQ(j["metallic_roughness"], "metallicRoughness");
  EXPECT_EQ(j["normal"], "normal");
  EXPECT_EQ(j["specular"], "specular");
  EXPECT_EQ(j["metallic_factor"], 0.0);
  // What a glTF reader samples: roughness from G and metallic from B of the grey roughness PNG (× metallicFactor 0),
  // the specular strength from the alpha channel, the base colour sRGB-encoded.
  EXPECT_NEAR(j["roughness_mean"].get<double>(), 0.4, 0.5 / 255);
  EXPECT_NEAR(j["metallic_mean"].get<double>(), 0, 1e-9);
  EXPECT_NEAR(j["specular_mean"].get<double>(), 0.3, 0.5 / 255);
  EXPECT_NEAR(j["base_color_mean"][0].get<double>(), linear_to_srgb(0.5f), 0.5 / 255);
  EXPECT_NEAR(j["normal_mean"][2].get<double>(), 0.5, 0.5 / 255);
  // The PNG-bytes form takes already encoded textures (the avatar folder's files: one encoding for both) and gives
  // the same file; it refuses bytes that are not PNG.
  const PbrPngs pngs{encode_png(to_srgb(maps.diffuse), 8), encode_png(maps.normal, 8), encode_png(maps.roughness, 8),
                     encode_png(specular_texture(maps.specular), 8)};
  EXPECT_EQ(glb_bytes(mesh, pngs), read_file(dir + "/a.glb"));
  PbrPngs broken = pngs;
  broken.specular = "not a png";
  EXPECT_THROW(glb_bytes(mesh, broken), InvalidInput);
  // Corrupting the header's length is caught by the oracle (it is not a rubber stamp).
  std::string bytes = read_file(dir + "/a.glb");
  bytes[8] ^= 1;
  testing::write_text(dir + "/b.glb", bytes);
  EXPECT_NE(std::system((std::string("/usr/bin/python3 ") + BARESKIN_GLB_ORACLE + " " + dir + "/b.glb 2>/dev/null").c_str()),
            0);
  Mesh no_uv = mesh;
  no_uv.UV.resize(0, 2);
  no_uv.FUV.resize(0, 3);
  EXPECT_THROW(glb_bytes(no_uv, maps), InvalidInput);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace bareskin::texture
