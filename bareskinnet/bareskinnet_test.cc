// BareSkinNet's task: gradients reach G and E (not the frozen F) in stage 2, the loss falls on a fixed batch, the
// stage switch resumes bit-identically, L_diff / L_light / the skin metrics against hand-computed values.
#include "bareskinnet/bareskinnet.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/image.h"
#include "core/png.h"
#include "core/test_options.h"
#include "core/test_util.h"
#include "core/shards.h"
#include "training/checkpoint.h"

namespace bareskin::bsn {
namespace {
namespace fs = std::filesystem;

constexpr int64_t kSize = 32;
const CoeffLayout kLayout{6, 4, 3, false};  // the toy model's sizes: K = 19

// Tiny shards in the face-sample layout (texgen faces): smooth random pictures, masks, 68 landmarks.
std::string write_faces(int count, uint64_t seed, int64_t size = kSize) {
  const std::string dir = testing::temp_dir() + "/faces";
  fs::create_directories(dir);
  shards::ShardWriter writer(dir, "faces", 4);
  torch::manual_seed(seed);
  auto png = [](const torch::Tensor& chw) {
    auto hwc = chw.clamp(0, 1).permute({1, 2, 0}).contiguous();
    Image im(int(hwc.size(1)), int(hwc.size(0)), int(hwc.size(2)));
    std::memcpy(im.pixels.data(), hwc.data_ptr<float>(), im.pixels.size() * sizeof(float));
    return encode_png(im);
  };
  auto smooth = [size](int64_t c) {
    return torch::nn::functional::interpolate(
               torch::rand({1, c, 4, 4}),
               torch::nn::functional::InterpolateFuncOptions().size(std::vector<int64_t>{size, size}).mode(torch::kBilinear).align_corners(false))[0];
  };
  for (int i = 0; i < count; ++i) {
    auto bare = smooth(3) * 0.6 + 0.2;
    auto before = (bare * (0.7 + 0.5 * smooth(1))).clamp(0, 1);
    auto makeup = (before * 0.6 + 0.4 * torch::tensor({0.8f, 0.2f, 0.3f}).view({3, 1, 1}) * smooth(1)).clamp(0, 1);
    auto disc = (torch::linspace(-1, 1, size).view({1, size}).pow(2) + torch::linspace(-1, 1, size).view({size, 1}).pow(2) < 0.6)
                    .to(torch::kFloat).unsqueeze(0);
    nlohmann::json meta = {{"subject", "mm/" + std::to_string(i)}, {"split", "train"}, {"style", "natural"}, {"has_truth", true}};
    auto lm = torch::rand({68, 2}) * size;
    for (int64_t k = 0; k < 68; ++k) meta["landmarks"].push_back({lm[k][0].item<float>(), lm[k][1].item<float>()});
    char key[16];
    std::snprintf(key, sizeof key, "%08d", i);
    writer.write({key, {{"makeup.png", png(makeup)}, {"before.png", png(before)}, {"bare.png", png(bare)},
                        {"skin.png", png(disc)}, {"face.png", png(disc)}, {"json", meta.dump()}}});
  }
  shards::write_manifest(dir, {writer.finish(), {}});
  return dir;
}

// A toy reconstruction net: pooled colour statistics to K coefficients (+ γ for a teacher).
ReconNet toy_net(bool light) {
  const int64_t out = kLayout.size() + (light ? 27 : 0);
  auto net = std::make_shared<torch::nn::SequentialImpl>(
      torch::nn::Conv2d(torch::nn::Conv2dOptions(3, 8, 3).stride(2).padding(1)), torch::nn::ReLU(),
      torch::nn::AdaptiveAvgPool2d(torch::nn::AdaptiveAvgPool2dOptions(1)), torch::nn::Flatten(),
      torch::nn::Linear(8, out));
  ReconNet r;
  r.module = net;
  r.forward = [net, light](const torch::Tensor& x) {
    auto y = net->forward(x);
    if (!light) return y;
    // γ near the ambient-only light that keeps colours (Deep3DFaceRecon's +0.8 offset included)
    auto g = y.narrow(1, kLayout.size(), 27) * 0.1;
    auto offset = torch::zeros({1, 27});
    for (int c = 0; c < 3; ++c) offset[0][c * 9] = 0.8;
    return torch::cat({y.narrow(1, 0, kLayout.size()), g + offset}, 1);
  };
  return r;
}

// A toy 3DMM render: a disc whose albedo is sigmoid(δ) per channel, lit by γ's ambient term, landmarks shifted by t.
FaceRender toy_render(const torch::Tensor& c, const torch::Tensor& gamma, int64_t s) {
  auto y = torch::linspace(-1, 1, s).view({1, 1, s, 1}), x = torch::linspace(-1, 1, s).view({1, 1, 1, s});
  auto mask = (x.pow(2) + y.pow(2) < 0.6).to(c.dtype()).expand({c.size(0), 1, s, s});
  auto albedo = torch::sigmoid(c.narrow(1, kLayout.id + kLayout.exp, 3)).view({-1, 3, 1, 1});
  FaceRender r;
  r.unlit = albedo * mask;
  r.lit = r.unlit * gamma.view({-1, 3, 9}).select(2, 0).view({-1, 3, 1, 1}) / (2 * std::sqrt(M_PI));
  r.mask = mask;
  r.landmarks = torch::full({c.size(0), 68, 2}, double(s) / 2) + c.narrow(1, kLayout.translation_offset(), 2).unsqueeze(1);
  return r;
}

// The face model's toy file (recon/face_model.h), written once per process.
std::string toy_model() {
  static const std::string path = [] {
    const std::string p = testing::temp_dir() + "/toy_model.safetensors";
    recon::ToyModelOptions o;
    o.grid = 16;
    o.resolution = 32;
    recon::save_toy_model(p, o);
    return p;
  }();
  return path;
}

Stage2Parts toy_parts() { return {toy_net(true), toy_net(false), toy_render, kLayout}; }

Options small_options(int stage) {
  Options o;
  o.stage = stage;
  o.size = kSize;
  o.g = {{"ngf", 8}};
  o.d = {{"ndf", 8}, {"n_layers", 2}};
  o.w3 = 0;  // LPIPS has its own tests; these stay fast
  return o;
}

data::Batch load_batch(const std::string& dir, const Options& o, int64_t batch) {
  data::LoaderOptions lo;
  lo.dataset = dir;
  lo.required = required_members(o);
  lo.batch_size = batch;
  lo.shuffle_buffer = 0;
  data::ShardLoader loader(lo);
  return loader.next();
}

bool has_gradient(torch::nn::Module& m) {
  for (auto& p : m.parameters())
    if (p.grad().defined() && p.grad().abs().sum().item<double>() > 0) return true;
  return false;
}

TEST(BareSkinNet, Stage2GradientsReachGAndEButNotTheFrozenTeacher) {
  const auto dir = write_faces(4, 1);
  for (const std::string recon : {"E", "F"}) {
    torch::manual_seed(0);
    Options o = small_options(2);
    o.recon = recon;
    auto parts = toy_parts();
    parts.renderer = model_renderer(std::make_shared<recon::FaceModel>(recon::FaceModel::load(toy_model())));
    BareSkinTask task(o, parts.teacher, parts.student, parts.renderer, parts.layout);
    auto batch = load_batch(dir, o, 4);
    auto modules = task.modules();
    for (auto& [name, m] : modules) m->train();
    task.loss(0, batch);
    auto l = task.loss(1, batch);
    for (const char* term : {"l1", "gan", "diff", "light", "land", "reg"}) EXPECT_TRUE(l.count(term)) << term;
    EXPECT_EQ(l.count("coeff"), recon == "E" ? 1u : 0u);
    torch::Tensor total = torch::zeros({});
    for (auto& [name, v] : l) total = total + v;
    total.backward();
    EXPECT_TRUE(has_gradient(*modules.at("G"))) << recon;
    if (recon == "E") {
      EXPECT_TRUE(has_gradient(*modules.at("E")));
    }
    EXPECT_FALSE(has_gradient(*modules.at("F"))) << recon;
    for (auto& p : modules.at("F")->parameters()) EXPECT_FALSE(p.requires_grad());
    // G's update set holds E (a second group) but never F.
    auto specs = task.optimizers();
    ASSERT_EQ(specs.size(), 2u);
    EXPECT_EQ(specs[1].groups.size(), recon == "E" ? 2u : 1u);
    // The diff term alone reaches G (the de-lighting path) and E.
    for (auto& [name, m] : modules) m->zero_grad();
    task.loss(0, batch);
    task.loss(1, batch).at("diff").backward();
    EXPECT_TRUE(has_gradient(*modules.at("G")));
    if (recon == "E") {
      EXPECT_TRUE(has_gradient(*modules.at("E")));
    }
  }
}

// A source that hands out the same batch at every step.
class FixedSource : public data::DataSource {
 public:
  explicit FixedSource(data::Batch b) : batch_(std::move(b)) {}
  data::Batch next() override { return batch_; }
  data::Cursor cursor() const override { return {0, 0}; }
  void seek(const data::Cursor&) override {}
  int64_t epoch_size() const override { return 1; }

 private:
  data::Batch batch_;
};

// Demakeup::flip_average: G's image is the mean of its pass on the faces and the mirror of its pass on the mirrored
// faces, so mirroring the photo mirrors the result (G alone, moved off its start, does not).
TEST(BareSkinNet, FlipAverageIsTheMeanOfGAndItsMirrorPassAndMirrorsWithThePhoto) {
  torch::manual_seed(0);
  Options o = small_options(1);
  o.head = "affine";
  BareSkinTask task(o);
  {
    torch::NoGradGuard no_grad;
    for (auto& p : task.generator()->parameters()) p.add_(torch::randn_like(p) * 0.05);
  }
  Demakeup d;
  d.G = task.generator();
  d.size = kSize;
  d.head = o.head;
  d.G->eval();
  auto x = torch::rand({2, 3, kSize, kSize});
  d.flip_average = false;
  auto once = run_generator(d, x), mirrored = run_generator(d, x.flip(-1)).flip(-1);
  ASSERT_GT((once - mirrored).abs().max().item<double>(), 1e-2);
  d.flip_average = true;
  auto both = run_generator(d, x);
  EXPECT_TRUE(torch::allclose(both, (once + mirrored) * 0.5, 1e-6, 1e-6));
  EXPECT_TRUE(torch::allclose(run_generator(d, x.flip(-1)), both.flip(-1), 1e-6, 1e-6));
}

// Both of our heads: G starts as its input bit for bit, and learns from there.
TEST(BareSkinNet, ResidualAndAffineGStartAsTheIdentityAndLearn) {
  ASSERT_EQ(small_options(1).head, "residual");  // ours is the default
  for (const std::string head : {"residual", "affine"}) {
    SCOPED_TRACE(head);
    torch::manual_seed(0);
    Options o = small_options(1);
    o.head = head;
    BareSkinTask task(o);
    auto x = torch::rand({2, 3, kSize, kSize});
    // Step 0: G's output is its input, bit for bit, in training (batch statistics) and in inference.
    EXPECT_TRUE(torch::equal(task.generate(x), x));
    Demakeup d;
    d.G = task.generator();
    d.size = kSize;
    d.head = head;
    d.G->eval();
    EXPECT_TRUE(torch::equal(run_generator(d, x), x));
    // A photo larger than G's size keeps its detail when G's maps apply at the photo's size (a G towards the before
    // image), and loses it when G's image is upsampled (a G towards the bare albedo): the check can fail.
    auto photo = torch::rand({2, 3, 2 * kSize, 2 * kSize});
    d.maps_at_photo_size = true;
    EXPECT_TRUE(torch::allclose(run_generator(d, photo), photo, 0, 1e-6));
    d.maps_at_photo_size = false;
    EXPECT_GT((run_generator(d, photo) - photo).abs().mean().item<double>(), 0.05);
    d.G->train();
    // ... and it is not stuck there: an L1 step towards another image reaches the last layer and moves the output.
    auto target = (x * 0.5 + 0.2).detach();
    torch::optim::Adam adam(task.generator()->parameters(), torch::optim::AdamOptions(1e-3));
    for (int i = 0; i < 20; ++i) {
      adam.zero_grad();
      (task.generate(x) - target).abs().mean().backward();
      adam.step();
    }
    const double before = (x - target).abs().mean().item<double>();
    const double after = (task.generate(x) - target).abs().mean().item<double>();
    EXPECT_LT(after, 0.9 * before) << before << " -> " << after;
  }
  // The affine head is x · exp(gain) + offset, per pixel and channel.
  auto x = torch::rand({1, 3, 4, 4}), y = torch::rand({1, 6, 4, 4}) - 0.5;
  auto expected = x * y.slice(1, 0, 3).exp() + y.slice(1, 3, 6);
  EXPECT_TRUE(torch::allclose(apply_head(x, y, "affine"), expected));
  // The paper's G (an image from the Tanh) starts far from its input.
  Options o = small_options(1);
  o.head = "image";
  torch::manual_seed(0);
  BareSkinTask paper(o);
  auto x2 = torch::rand({2, 3, kSize, kSize});
  EXPECT_GT((paper.generate(x2) - x2).abs().mean().item<double>(), 0.05);
  // Runs written before `head` existed (options_of_run, which load_generator reads them with): no key is the paper's
  // G, `residual` true the residual head; a run's head survives its configuration.
  EXPECT_EQ(options_of_run(nlohmann::json::object()).head, "image");
  EXPECT_EQ(options_of_run({{"residual", true}}).head, "residual");
  EXPECT_EQ(options_of_run({{"residual", false}}).head, "image");
  Options affine = small_options(1);
  affine.head = "affine";
  EXPECT_EQ(options_of_run(nlohmann::json(affine)).head, "affine");
  EXPECT_THROW(options_of_run({{"head", "gain"}}), InvalidInput);
}

// The options through core/json_options.h: the default configuration is written as it always was (same keys, values
// and JSON types: config.json's bytes), non-default values round-trip, unknown keys are refused.
TEST(BareSkinNet, OptionsRoundTripAndRefuseUnknownKeys) {
  const nlohmann::json expected = {
      {"stage", 1},         {"target", "before"},    {"head", "residual"},    {"size", 256},
      {"g", nlohmann::json::object()},               {"d", nlohmann::json::object()},
      {"gan", "vanilla"},   {"lpips_trunk", "vgg16-random"},                  {"w1", 100.0},
      {"w2", 1.0},          {"w3", 40.0},            {"w_coeff", 0.1},        {"w_land", 0.08},
      {"w_diff", 100.0},    {"w_light", 100.0},      {"w_reg", 1e-3},         {"recon", "E"},
      {"tune_f", false},    {"lr_g", 2e-5},          {"lr_d", 2e-5},          {"lr_e", 1e-4},
      {"lr_f", 1e-5},       {"beta1", 0.5},          {"beta2", 0.999},        {"ema", 0.0}};
  EXPECT_EQ(nlohmann::json(Options{}).dump(), expected.dump());
  testing::expect_options_json<Options>({{"stage", 2},
                                         {"target", "bare"},
                                         {"head", "affine"},
                                         {"size", 128},
                                         {"g", {{"ngf", 8}}},
                                         {"d", {{"ndf", 8}}},
                                         {"gan", "lsgan"},
                                         {"lpips_trunk", "facenet"},
                                         {"w1", 10.0},
                                         {"w_reg", 0.0},
                                         {"recon", "F"},
                                         {"tune_f", true},
                                         {"lr_g", 1e-4},
                                         {"beta1", 0.9},
                                         {"ema", 0.99},
                                         {"lr_decay", 0.5},
                                         {"clip_grad_norm", 10.0},
                                         {"w_level", 1.0},
                                         {"w_makeup", 50.0},
                                         {"makeup_hue", 0.5},
                                         {"makeup_paint", 0.25}});
  // The options added since the paper's are written only when set, so the configuration of a run from before one
  // existed matches on resume.
  const nlohmann::json defaults = Options{};
  for (const char* key : {"lr_decay", "clip_grad_norm", "w_level", "w_makeup", "makeup_hue", "makeup_paint"})
    EXPECT_FALSE(defaults.contains(key)) << key;
  // face_api is read (a folder of this machine) but never written into a run's configuration.
  const Options with_folder = nlohmann::json({{"face_api", "/tmp/face-api"}}).get<Options>();
  EXPECT_EQ(with_folder.face_api, "/tmp/face-api");
  EXPECT_FALSE(nlohmann::json(with_folder).contains("face_api"));
  try {
    (void)nlohmann::json({{"w_lvl", 1.0}}).get<Options>();
    FAIL() << "a misspelt key was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("unknown key 'w_lvl'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("w_level"), std::string::npos) << e.what();
  }
  // The run's configuration records the task and the run's keys, nothing of this machine.
  RunOptions ro;
  ro.run_dir = "/tmp/run";
  const nlohmann::json run = ro;
  EXPECT_EQ(run.at("task"), nlohmann::json(ro.task));
  EXPECT_FALSE(run.contains("run_dir"));
  EXPECT_EQ(run.size(), 9u);
  EXPECT_TRUE(run.at("seed").is_number_unsigned());
}

TEST(BareSkinNet, LossFallsOnAFixedBatch) {
  const auto dir = write_faces(4, 2);
  torch::manual_seed(0);
  Options o = small_options(1);
  o.lr_g = o.lr_d = 2e-3;
  BareSkinTask task(o);
  FixedSource source(load_batch(dir, o, 4));
  auto run = [&](const std::string& dir, int64_t steps) {
    train::TrainerOptions to;
    to.run_dir = dir;
    to.steps = steps;
    to.log_every = 5;
    to.checkpoint_every = 0;
    to.eval_every = 0;
    to.sample_every = 0;
    to.progress = false;
    return train::Trainer(to, task, source, nullptr).run().last_losses.at("G/l1");
  };
  const auto tmp = testing::temp_dir();
  const double first = run(tmp + "/a", 1);
  const double last = run(tmp + "/b", 40);
  EXPECT_LT(last, 0.5 * first) << "L1 x100 from " << first << " to " << last;
}

TEST(BareSkinNet, BareTargetIsTheAlbedoOnTheFaceAndTheInputElsewhere) {
  const auto dir = write_faces(4, 5);
  Options o = small_options(1);
  o.target = "bare";
  BareSkinTask task(o);
  const data::Batch batch = load_batch(dir, o, 4);  // needs face.png: required_members asks for it
  const auto t = task.target(batch), face = batch.at("face") > 0.5;
  const auto bare = batch.at("bare"), makeup = batch.at("makeup");
  ASSERT_TRUE(face.any().item<bool>() && (~face).any().item<bool>());
  EXPECT_TRUE(torch::allclose(t.masked_select(face.expand_as(t)), bare.masked_select(face.expand_as(t)), 0, 1e-6));
  EXPECT_TRUE(torch::allclose(t.masked_select((~face).expand_as(t)), makeup.masked_select((~face).expand_as(t)), 0, 1e-6));
  // the unmasked bare image differs off the face: the check can fail
  EXPECT_GT((bare - makeup).abs().masked_select((~face).expand_as(t)).mean().item<double>(), 0.05);
}

TEST(BareSkinNet, BelowTheShardsSizeTheTargetAndTheSkinMetricAgreeOnTheFacesOutline) {
  const auto dir = write_faces(4, 6, 2 * kSize);
  Options o = small_options(1);
  o.target = "bare";
  BareSkinTask task(o);
  data::Batch batch = load_batch(dir, o, 4);
  const auto face = batch.at("face"), makeup = batch.at("makeup");
  batch.tensors["bare"] = batch.at("bare") * face;  // black off the face, as texgen faces writes it
  const auto bare = batch.at("bare");
  namespace F = torch::nn::functional;
  auto half = [](const torch::Tensor& t) { return F::avg_pool2d(t, F::AvgPool2dFuncOptions(2)); };
  const auto t = task.target(batch);
  EXPECT_TRUE(torch::allclose(t, half(face * bare + (1 - face) * makeup), 0, 1e-6));
  // A G that gives this target is perfect on the skin: where a pixel's whole footprint is skin, target = bare truth.
  const auto skin = whole_footprint(half(batch.at("skin")));
  EXPECT_GT(masked_psnr(t, half(bare), skin).min().item<double>(), 100);
  // On the outline (half covered or more, not whole) the bare truth is darkened: there the check can fail.
  const auto outline = (half(batch.at("skin")) >= 0.5).to(skin.dtype()) - skin;
  ASSERT_GT(outline.sum().item<double>(), 0);
  EXPECT_GT(((t - half(bare)).abs() * outline).sum().item<double>() / (3 * outline.sum().item<double>()), 0.05);
  // Resizing the members first, as before, gave the outline's face part its coverage twice.
  const auto old = half(face) * half(bare) + (1 - half(face)) * half(makeup);
  EXPECT_GT((old - t).abs().max().item<double>(), 0.05);
}

std::map<std::string, torch::Tensor> weights(const std::string& checkpoint, const std::string& module, BareSkinTask& task) {
  auto m = task.modules().at(module);
  train::load_module_weights(checkpoint, module, *m);
  std::map<std::string, torch::Tensor> out;
  for (auto& item : m->named_parameters()) out[item.key()] = item.value().clone();
  for (auto& item : m->named_buffers()) out[item.key()] = item.value().clone();
  return out;
}

TEST(BareSkinNet, StageSwitchResumesBitIdentically) {
  const auto dir = write_faces(8, 3);
  RunOptions ro;
  ro.task = small_options(1);
  ro.task.ema = 0.5;      // the moving average (a module of its own) resumes with the rest
  ro.task.w_level = 10;
  ro.train_data = dir;
  ro.steps1 = 3;
  ro.steps2 = 4;
  ro.seed = 7;
  ro.trainer.log_every = 1;
  ro.trainer.checkpoint_every = 1;
  ro.trainer.eval_every = 0;
  ro.trainer.sample_every = 0;
  ro.trainer.progress = false;
  // Uninterrupted: both stages in one call.
  ro.run_dir = testing::temp_dir() + "/a";
  auto a = train_two_stages(ro, toy_parts);
  EXPECT_EQ(a.stage1.steps, 3);
  EXPECT_EQ(a.stage2.steps, 4);
  // Interrupted at the switch: stage 1 alone, then stage 2 in two calls (resume), with fresh tasks each time.
  RunOptions rb = ro;
  rb.run_dir = testing::temp_dir() + "/b";
  rb.steps2 = 0;
  train_two_stages(rb, toy_parts);
  rb.steps2 = 1;
  rb.trainer.resume = true;
  train_two_stages(rb, toy_parts);
  rb.steps2 = 4;
  auto b = train_two_stages(rb, toy_parts);
  EXPECT_EQ(b.stage1.steps, 0) << "a finished stage 1 is not run again";
  EXPECT_EQ(b.stage2.steps, 4);
  Options o2 = ro.task;
  o2.stage = 2;
  auto parts = toy_parts();
  BareSkinTask probe(o2, parts.teacher, parts.student, parts.renderer, parts.layout);
  for (const char* module : {"G", "G_ema", "D", "E", "F"}) {
    auto wa = weights(ro.run_dir + "/stage2/checkpoint.safetensors", module, probe);
    auto wb = weights(rb.run_dir + "/stage2/checkpoint.safetensors", module, probe);
    ASSERT_EQ(wa.size(), wb.size());
    for (auto& [name, t] : wa) EXPECT_TRUE(torch::equal(t, wb.at(name))) << module << "." << name;
  }
  // Stage 2 really moved G and E away from the switch, and F stayed the teacher it was.
  auto g1 = weights(ro.run_dir + "/stage1/checkpoint.safetensors", "G", probe);
  auto g2 = weights(ro.run_dir + "/stage2/checkpoint.safetensors", "G", probe);
  bool moved = false;
  for (auto& [name, t] : g1) moved = moved || !torch::equal(t, g2.at(name));
  EXPECT_TRUE(moved);
}

TEST(BareSkinNet, DiffAndLightLossesMatchAHandComputedCase) {
  // A 2x2 image, one channel repeated: the region is the top row (weights 1 and 0.5: a soft edge).
  auto mask = torch::tensor({1.0, 0.5, 0.0, 0.0}, torch::kDouble).view({1, 1, 2, 2});
  auto unlit = torch::tensor({0.2, 0.4, 0.9, 0.9}, torch::kDouble).view({1, 1, 2, 2}).expand({1, 3, 2, 2});
  // G's output as sRGB 0.5 (linear 0.214041) and 0.04 (linear 0.04/12.92 = 0.00309598)
  auto g_srgb = torch::tensor({0.5, 0.04, 0.1, 0.1}, torch::kDouble).view({1, 1, 2, 2}).expand({1, 3, 2, 2});
  const double lin_half = std::pow((0.5 + 0.055) / 1.055, 2.4), lin_004 = 0.04 / 12.92;
  const double expected_diff = (1.0 * std::abs(0.2 - lin_half) + 0.5 * std::abs(0.4 - lin_004)) / 1.5;
  EXPECT_NEAR(diff_loss(unlit, srgb_to_linear(g_srgb), mask).item<double>(), expected_diff, 1e-9);
  // With the gain: k = Σ m·unlit·g / Σ m·unlit² over the region, then the same L1 of k·unlit.
  const double k = (1.0 * 0.2 * lin_half + 0.5 * 0.4 * lin_004) / (1.0 * 0.04 + 0.5 * 0.16);
  const double expected_gain = (1.0 * std::abs(k * 0.2 - lin_half) + 0.5 * std::abs(k * 0.4 - lin_004)) / 1.5;
  EXPECT_NEAR(diff_loss(unlit, srgb_to_linear(g_srgb), mask, true).item<double>(), expected_gain, 1e-9);
  // A render that is G's output at another level costs nothing with the gain, and without it does.
  EXPECT_NEAR(diff_loss(srgb_to_linear(g_srgb) * 0.6, srgb_to_linear(g_srgb), mask, true).item<double>(), 0, 1e-12);
  EXPECT_GT(diff_loss(srgb_to_linear(g_srgb) * 0.6, srgb_to_linear(g_srgb), mask).item<double>(), 0.01);
  // lit = unlit × (Y00 · γ0) with γ0 = 0.8·2√π → a factor 0.8; the before image is linear 0.1 and 0.3.
  auto before = torch::tensor({0.1, 0.3, 0.0, 0.0}, torch::kDouble).view({1, 1, 2, 2}).expand({1, 3, 2, 2});
  auto lit = unlit * 0.8;
  const double expected_light = (1.0 * std::abs(0.16 - 0.1) + 0.5 * std::abs(0.32 - 0.3)) / 1.5;
  EXPECT_NEAR(light_loss(lit, before, mask).item<double>(), expected_light, 1e-12);
  // An empty region gives 0, not NaN.
  EXPECT_EQ(light_loss(lit, before, torch::zeros_like(mask)).item<double>(), 0.0);
}

TEST(BareSkinNet, MakeupRegionIsWhereTheMakeupChangedTheFace) {
  // Four pixels: mean |makeup − before| over the channels 0.03 (changed), 0.01 (not), 0.5 off the face, 0.021 where
  // one channel alone moved by 0.063 (changed: the mean, not the largest channel, is compared with 0.02).
  auto before = torch::full({1, 3, 2, 2}, 0.5, torch::kDouble);
  auto makeup = before.clone();
  makeup.select(3, 0).select(2, 0) += 0.03;        // pixel (0, 0), every channel
  makeup.select(3, 1).select(2, 0) -= 0.01;        // pixel (0, 1)
  makeup.select(3, 0).select(2, 1) += 0.5;         // pixel (1, 0), off the face
  makeup.select(3, 1).select(2, 1)[0][0] += 0.063;  // pixel (1, 1), the red channel alone
  auto face = torch::tensor({1.0, 1.0, 0.0, 0.6}, torch::kDouble).view({1, 1, 2, 2});
  auto region = makeup_region(makeup, before, face);
  EXPECT_TRUE(torch::equal(region, torch::tensor({1.0, 0.0, 0.0, 1.0}, torch::kDouble).view({1, 1, 2, 2}))) << region;
}

TEST(BareSkinNet, MakeupHueTurnsTheMakeupsChangeAboutTheGreyAxis) {
  data::Example e;
  e.tensors["before"] = torch::full({3, 1, 4}, 0.5);
  // Pixel 0 untouched, pixel 1 a red change, pixel 2 a grey change (darker), pixel 3 a change that leaves [0, 1].
  e.tensors["makeup"] = torch::tensor({0.5f, 0.8f, 0.3f, 1.0f,   // R
                                       0.5f, 0.5f, 0.3f, 0.1f,   // G
                                       0.5f, 0.5f, 0.3f, 0.1f})  // B
                            .view({3, 1, 4});
  const auto original = e.tensors["makeup"].clone();
  // Find seeds that turn and that do not, at probability 0.5; the same seed turns the same way.
  int turned = 0, kept = 0;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    data::Example t = e;
    t.tensors["makeup"] = original.clone();
    rotate_makeup_hue(t, seed, 0.5);
    const auto& m = t.tensors["makeup"];
    if (torch::equal(m, original)) {
      ++kept;
      continue;
    }
    ++turned;
    const auto change = (m - 0.5).select(1, 0);  // [3, 4]
    EXPECT_NEAR(change.select(1, 0).abs().max().item<double>(), 0.0, 1e-6);  // untouched stays
    // The red change (0.3, 0, 0) keeps its length and its grey part (0.1 per channel).
    EXPECT_NEAR(change.select(1, 1).norm().item<double>(), 0.3, 1e-5);
    EXPECT_NEAR(change.select(1, 1).mean().item<double>(), 0.1, 1e-6);
    // A grey change has no hue to turn.
    EXPECT_TRUE(torch::allclose(change.select(1, 2), torch::full({3}, -0.2f), 0, 1e-6));
    EXPECT_GE(m.min().item<float>(), 0.0f);
    EXPECT_LE(m.max().item<float>(), 1.0f);
    data::Example again = e;
    again.tensors["makeup"] = original.clone();
    rotate_makeup_hue(again, seed, 0.5);
    EXPECT_TRUE(torch::equal(again.tensors["makeup"], m));
  }
  EXPECT_GT(turned, 10);
  EXPECT_GT(kept, 10);
  // At probability 1 every seed turns; at 0 none does; without a before member nothing happens.
  data::Example always = e;
  rotate_makeup_hue(always, 3, 1.0);
  EXPECT_FALSE(torch::equal(always.tensors["makeup"], original));
  data::Example never = e;
  rotate_makeup_hue(never, 3, 0.0);
  EXPECT_TRUE(torch::equal(never.tensors["makeup"], original));
  data::Example alone;
  alone.tensors["makeup"] = original.clone();
  rotate_makeup_hue(alone, 3, 1.0);
  EXPECT_TRUE(torch::equal(alone.tensors["makeup"], original));
}

TEST(BareSkinNet, MakeupPaintCoversWhereTheMakeupChangedTheFaceMostLitByThePhotosLight) {
  // Four pixels in a row above the split (row 0 of 2) and the same below: untouched, foundation (a change of
  // 0.02), lipstick (0.3 on R), and lipstick off the face.
  data::Example e;
  e.tensors["before"] = torch::full({3, 2, 4}, 0.5);
  e.tensors["bare"] = torch::full({3, 2, 4}, 0.7);  // the light darkens the albedo: before / bare < 1
  auto makeup = torch::full({3, 2, 4}, 0.5);
  makeup.select(1, 0).select(1, 1).fill_(0.52);
  makeup.select(1, 1).select(1, 1).fill_(0.52);
  for (int64_t c : {2, 3}) {
    makeup.select(0, 0).select(0, 0)[c] = 0.8;
    makeup.select(0, 0).select(0, 1)[c] = 0.8;
  }
  e.tensors["makeup"] = makeup;
  e.tensors["face"] = torch::ones({1, 2, 4});
  e.tensors["face"].select(2, 3).fill_(0);
  const auto original = makeup.clone();
  int painted = 0;
  for (uint64_t seed = 0; seed < 40; ++seed) {
    data::Example t = e;
    t.tensors["makeup"] = original.clone();
    paint_makeup(t, seed, 0.5);
    const auto& m = t.tensors["makeup"];
    if (torch::equal(m, original)) continue;
    ++painted;
    // Untouched, foundation and off the face stay; the lipstick is painted over.
    for (int64_t c : {0, 1, 3}) EXPECT_TRUE(torch::allclose(m.select(2, c), original.select(2, c), 0, 1e-6)) << c;
    EXPECT_GT((m.select(2, 2) - original.select(2, 2)).abs().max().item<double>(), 1e-3);
    // The layer is lit as the photo: in linear light no brighter than its colour times before / bare (< 1),
    // composed over the makeup (the lipstick's opacity up to 1).
    const double light = (srgb_to_linear(torch::tensor(0.5)) / srgb_to_linear(torch::tensor(0.7))).item<double>();
    const auto lit = srgb_to_linear(m.select(2, 2));
    EXPECT_LE(lit.max().item<double>(),
              std::max(srgb_to_linear(original.select(2, 2)).max().item<double>(), light) + 1e-4);
    // The same seed paints the same.
    data::Example again = e;
    again.tensors["makeup"] = original.clone();
    paint_makeup(again, seed, 0.5);
    EXPECT_TRUE(torch::equal(again.tensors["makeup"], m));
    // Above and below the split, two colours.
    const auto top = m.select(1, 0).select(1, 2), bottom = m.select(1, 1).select(1, 2);
    EXPECT_FALSE(torch::allclose(top, bottom, 0, 1e-4));
  }
  EXPECT_GT(painted, 10);
  EXPECT_LT(painted, 30);
  data::Example alone;  // without bare: nothing to light the layer with
  alone.tensors["makeup"] = original.clone();
  alone.tensors["before"] = e.tensors["before"];
  paint_makeup(alone, 3, 1.0);
  EXPECT_TRUE(torch::equal(alone.tensors["makeup"], original));
}

TEST(BareSkinNet, SkinMetricsAndRegularisation) {
  // A constant error of 0.1 on the skin and anything off it: PSNR exactly 20 dB.
  auto a = torch::full({2, 3, 16, 16}, 0.5, torch::kDouble);
  auto mask = torch::zeros({2, 1, 16, 16}, torch::kDouble);
  mask.narrow(2, 4, 8).narrow(3, 4, 8).fill_(1);
  auto b = a + 0.1 * mask - 0.4 * (1 - mask);
  auto p = masked_psnr(a, b, mask);
  EXPECT_NEAR(p[0].item<double>(), 20.0, 1e-9);
  EXPECT_NEAR(masked_ssim(a, a, mask)[1].item<double>(), 1.0, 1e-12);
  EXPECT_LT(masked_ssim(a, b + 0.05 * torch::randn_like(b), mask)[0].item<double>(), 0.9);
  // Against a truth that exists on a domain alone (the bare albedo, black off the face), windows on the domain's edge
  // compare the pair there: what G shows off it (hair, background) does not count.
  auto truth = a.clone() + 0.05 * torch::randn_like(a) * mask;
  auto g = truth * mask + (1 - mask) * 0.7;
  auto black = truth * mask;
  EXPECT_NEAR(masked_ssim(g, black, mask, mask)[0].item<double>(), 1.0, 1e-12);
  EXPECT_LT(masked_ssim(g, black, mask)[0].item<double>(), 0.9);
  EXPECT_FALSE(truth_domain("before", mask).defined());
  EXPECT_TRUE(torch::equal(truth_domain("bare", mask * 0.9995), mask));
  // L_reg: Σα² + Σβ² + Σδ² per face, batch mean; R and t do not count.
  auto c = torch::zeros({2, kLayout.size()});
  c[0][0] = 1;
  c[0][12] = 2;
  c[1][kLayout.translation_offset()] = 50;  // t
  EXPECT_NEAR(reg_loss(c, kLayout).item<double>(), 2.5, 1e-6);
  EXPECT_NEAR(landmark_loss(torch::ones({1, 68, 2}), torch::zeros({1, 68, 2}), 4.0).item<double>(), 32.0, 1e-6);
  // L_level: the mean colours on the mask differ by +0.1 (R), 0 (G: the errors cancel), −0.3 (B) in image 0 and by
  // nothing in image 1 (it differs only off the mask): (0.1 + 0 + 0.3) / 6.
  auto lb = a.clone();
  lb[0][0] += 0.1 * mask[0][0];
  lb[0][1].narrow(0, 4, 4).narrow(1, 4, 8) += 0.2;
  lb[0][1].narrow(0, 8, 4).narrow(1, 4, 8) -= 0.2;
  lb[0][2] -= 0.3 * mask[0][0];
  lb[1] += 0.5 * (1 - mask[1]);
  EXPECT_NEAR(level_loss(lb, a, mask).item<double>(), 0.4 / 6, 1e-12);
}

// --lr-decay: every group's rate is constant up to the fraction of each stage's steps, then falls linearly to 0 at
// the stage's end (the rates the Trainer logs per step); L_level is trained (a loss of its own in the log); the
// gradient clip reaches both stages' optimizers (each logs its norm before clipping).
TEST(BareSkinNet, LearningRateDecaysOverTheLastPartOfEachStage) {
  const auto dir = write_faces(8, 5);
  RunOptions ro;
  ro.task = small_options(1);
  ro.task.lr_decay = 0.5;
  ro.task.w_level = 10;
  ro.task.clip_grad_norm = 1e3;
  ro.train_data = dir;
  ro.steps1 = 4;
  ro.steps2 = 6;
  ro.run_dir = testing::temp_dir() + "/decay";
  ro.trainer.log_every = 1;
  ro.trainer.checkpoint_every = 100;  // at the end of each stage
  ro.trainer.eval_every = 0;
  ro.trainer.sample_every = 0;
  ro.trainer.progress = false;
  train_two_stages(ro, toy_parts);
  auto read = [](const std::string& csv) {  // name → value per logged step
    std::map<std::string, std::vector<double>> v;
    std::istringstream in(read_file(csv));
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      const auto a = line.find(','), b = line.find(',', a + 1);
      v[line.substr(a + 1, b - a - 1)].push_back(std::stod(line.substr(b + 1)));
    }
    return v;
  };
  const auto m1 = read(ro.run_dir + "/stage1/metrics.csv"), m2 = read(ro.run_dir + "/stage2/metrics.csv");
  const double g = ro.task.lr_g, e = ro.task.lr_e;
  const std::vector<double> f1{1, 1, 1, 0.5}, f2{1, 1, 1, 1, 2.0 / 3, 1.0 / 3};  // decay from step 2 of 4, 3 of 6
  ASSERT_EQ(m1.at("lr/G/G").size(), f1.size());
  ASSERT_EQ(m2.at("lr/G/E").size(), f2.size());
  for (size_t i = 0; i < f1.size(); ++i) {
    EXPECT_NEAR(m1.at("lr/G/G")[i], g * f1[i], 1e-7 * g) << i;
    EXPECT_NEAR(m1.at("lr/D/D")[i], ro.task.lr_d * f1[i], 1e-7 * g) << i;
  }
  for (size_t i = 0; i < f2.size(); ++i) {
    EXPECT_NEAR(m2.at("lr/G/G")[i], g * f2[i], 1e-7 * g) << i;
    EXPECT_NEAR(m2.at("lr/G/E")[i], e * f2[i], 1e-7 * e) << i;
  }
  EXPECT_EQ(m2.at("G/level").size(), f2.size());
  EXPECT_GT(m1.at("G/level")[0], 0);
  for (const auto* m : {&m1, &m2})
    for (const char* norm : {"G/grad_norm", "D/grad_norm"}) {
      ASSERT_TRUE(m->count(norm)) << norm;
      EXPECT_GT(m->at(norm)[0], 0) << norm;
    }
  Options bad;
  EXPECT_THROW(from_json({{"lr_decay", 1.5}}, bad), InvalidInput);
  EXPECT_THROW(from_json({{"w_level", -1}}, bad), InvalidInput);
  EXPECT_THROW(from_json({{"makeup_hue", 1.5}}, bad), InvalidInput);
  EXPECT_THROW(from_json({{"makeup_paint", -0.1}}, bad), InvalidInput);
  EXPECT_THROW(from_json({{"clip_grad_norm", -1}}, bad), InvalidInput);
}

TEST(BareSkinNet, UnwarpRecoversTheAlbedoTextureOfARenderedFace) {
  // Oracle: the face model's own albedo texture. Render the unlit face at known coefficients, unwarp the render into
  // the UV through the same coefficients: every seen texel must hold the texture's colour there.
  Demakeup d = Demakeup::with_model(toy_model());
  const auto layout = d.model->layout(true);
  torch::manual_seed(5);
  auto c = torch::zeros({1, layout.size()});
  c.narrow(1, 0, layout.rotation_offset()).normal_(0, 0.5);
  c[0][layout.rotation_offset() + 1] = 0.3;  // yaw: one side turns away
  const int64_t S = 256, R = 32;
  auto render = d.model->render(c, recon::canonical_camera(int(S)));
  auto [uv, seen] = unwarp_to_uv(d, render.albedo, c, R);
  auto truth = d.model->albedo_texture(d.model->split(c).delta);  // [1, 3, 32, 32], row 0 = v 1
  auto in_layout = (truth.abs().sum(1, true) > 0).to(torch::kFloat);
  const double seen_fraction = seen.sum().item<double>() / in_layout.sum().item<double>();
  EXPECT_GT(seen_fraction, 0.3);
  EXPECT_LT(seen_fraction, 0.999) << "a turned face hides part of its texture";
  // Away from the layout's edges (where a texel mixes in the background) the colours agree.
  auto inner = seen * (1 - torch::max_pool2d(1 - seen, 3, 1, 1));
  auto err = ((uv - truth).abs() * inner).sum() / (3 * inner.sum());
  EXPECT_GT(inner.sum().item<double>(), 50);
  EXPECT_LT(err.item<double>(), 0.02) << "mean |unwarped - texture| over " << inner.sum().item<double>() << " texels";
  // A texture with nothing in common: far larger error (the check can fail).
  auto err_flipped = ((uv - truth.flip(3)).abs() * inner).sum() / (3 * inner.sum());
  EXPECT_GT(err_flipped.item<double>(), 3 * err.item<double>());
}

TEST(BareSkinNet, BadOptionsAndAblationRows) {
  Options o;
  EXPECT_THROW(from_json({{"target", "after"}}, o), InvalidInput);
  EXPECT_THROW(from_json({{"size", 48}}, o), InvalidInput);
  EXPECT_THROW(ablation_preset("h", o), InvalidInput);
  Options f;
  ablation_preset("f", f);
  EXPECT_EQ(f.w_light, 0);
  EXPECT_EQ(f.recon, "E");
  Options e;
  ablation_preset("e", e);
  EXPECT_TRUE(e.tune_f);
  EXPECT_EQ(e.recon, "F");
  Options s2 = small_options(2);
  EXPECT_THROW(BareSkinTask task(s2), InvalidInput);  // stage 2 without teacher and renderer
}

// G_ema (Options::ema) against an average computed here from G's weights along its trajectory (the oracle: the
// formula applied to snapshots, not ema_update); a two-stage run keeps it in the checkpoint and load_generator
// (eval.json, demakeup) reads it instead of G.
TEST(BareSkinNet, EmaOfGIsTheMovingAverageOfItsTrajectoryAndInferenceUsesIt) {
  EXPECT_DOUBLE_EQ(ema_decay(0.99, 0), 0.1);
  EXPECT_DOUBLE_EQ(ema_decay(0.99, 10), 11.0 / 20);
  EXPECT_DOUBLE_EQ(ema_decay(0.9, 1000), 0.9);
  Options bad;
  EXPECT_THROW(from_json({{"ema", 1.0}}, bad), InvalidInput);
  EXPECT_THROW(from_json({{"ema", -0.1}}, bad), InvalidInput);

  // Making the average draws nothing from the random stream: what is drawn after (LPIPS trunk, dropout) is the same
  // with and without it, so --ema-g never changes how G trains.
  auto next_draw = [](double ema) {
    Options oe = small_options(1);
    oe.ema = ema;
    torch::manual_seed(5);
    BareSkinTask t(oe);
    return torch::rand({8});
  };
  EXPECT_TRUE(torch::equal(next_draw(0), next_draw(0.5)));

  const auto dir = write_faces(4, 11);
  torch::manual_seed(0);
  Options o = small_options(1);
  o.ema = 0.5;
  BareSkinTask task(o);
  const data::Batch batch = load_batch(dir, o, 4);
  auto state = [](torch::nn::Module& m) {  // floating parameters and buffers by name
    std::map<std::string, torch::Tensor> s;
    for (auto& item : m.named_parameters()) s[item.key()] = item.value().detach().clone().to(torch::kDouble);
    for (auto& item : m.named_buffers())
      if (item.value().is_floating_point()) s[item.key()] = item.value().clone().to(torch::kDouble);
    return s;
  };
  auto G = task.generator();
  auto expected = state(*G);  // the average starts at G
  torch::optim::Adam adam(G->parameters(), torch::optim::AdamOptions(1e-2));
  const int steps = 4;
  for (int n = 0; n < steps; ++n) {
    const double d = std::min(0.5, (1.0 + n) / (10.0 + n));
    for (auto& [name, w] : state(*G)) expected[name] = d * expected[name] + (1 - d) * w;
    task.loss(0, batch);
    adam.zero_grad();
    train::Losses l = task.loss(1, batch);
    torch::Tensor total = torch::zeros({});
    for (auto& [name, v] : l) total = total + v;
    total.backward();
    adam.step();
  }
  EXPECT_EQ(task.ema_updates(), steps);
  const auto got = state(*task.generator_ema()), now = state(*G);
  double moved = 0;
  ASSERT_EQ(got.size(), expected.size());
  for (auto& [name, t] : expected) {
    EXPECT_LT((got.at(name) - t).abs().max().item<double>(), 1e-6) << name;
    moved = std::max(moved, (got.at(name) - now.at(name)).abs().max().item<double>());
  }
  EXPECT_GT(moved, 1e-4) << "the average lags G: the check can fail";

  // Through a run: the checkpoint holds G_ema, and load_generator gives it (not G) to inference.
  RunOptions ro;
  ro.task = o;
  ro.train_data = dir;
  ro.steps1 = 3;
  ro.steps2 = 0;
  ro.run_dir = testing::temp_dir() + "/ema";
  ro.trainer.checkpoint_every = 3;
  ro.trainer.eval_every = 0;
  ro.trainer.sample_every = 0;
  ro.trainer.progress = false;
  train_two_stages(ro, toy_parts);
  const std::string ck = ro.run_dir + "/stage1/checkpoint.safetensors";
  BareSkinTask probe(o);
  auto g = weights(ck, "G", probe);
  auto ema = weights(ck, "G_ema", probe);
  EXPECT_EQ(ema.at("updates").item<int64_t>(), 3);
  Demakeup loaded = load_generator(ro.run_dir);
  double to_ema = 0, to_g = 0;
  for (auto& item : loaded.G->named_parameters()) {
    to_ema = std::max(to_ema, (item.value() - ema.at("G." + item.key())).abs().max().item<double>());
    to_g = std::max(to_g, (item.value() - g.at(item.key())).abs().max().item<double>());
  }
  EXPECT_EQ(to_ema, 0);
  EXPECT_GT(to_g, 1e-5);
}

// G at inference (nets::UNetInference: batch norms folded, transposed convolutions as phase convolutions) against
// the module itself in eval mode, with non-trivial batch statistics, for every norm and upsampler; and through
// run_generator.
TEST(BareSkinNet, InferenceFormOfGEqualsTheModuleInEvalMode) {
  for (const char* norm : {"batch", "instance", "none"})
    for (const char* up : {"transpose", "resize_conv"}) {
      torch::manual_seed(3);
      nets::UNetOptions uo;
      uo.ngf = 8;
      uo.num_downs = 5;
      uo.norm = norm;
      uo.upsample = up;
      uo.max_mult = std::string(norm) == "batch" ? 32 : 8;  // wider coarse levels too
      uo.out_channels = std::string(up) == "transpose" ? 6 : 3;  // the affine head's six channels, too
      nets::UNet net(uo);
      {
        torch::NoGradGuard no_grad;
        // without a norm the activations grow level by level: smaller weights keep them near 1
        const double scale = std::string(norm) == "none" ? 0.05 : 0.2;
        for (auto& p : net->named_parameters()) p.value().copy_(torch::randn_like(p.value()) * scale);
        for (auto& b : net->named_buffers())
          if (b.key().find("running_mean") != std::string::npos) b.value().copy_(torch::randn_like(b.value()) * 0.3);
          else if (b.key().find("running_var") != std::string::npos) b.value().copy_(torch::rand_like(b.value()) + 0.5);
      }
      net->eval();
      auto x = torch::rand({2, 3, 64, 64}) * 2 - 1;
      torch::Tensor ref;
      {
        torch::NoGradGuard no_grad;
        ref = net->forward(x);
      }
      ASSERT_GT(ref.abs().max().item<double>(), 0.05);  // not a saturated or dead net
      for (int64_t side : {0, 2, 8}) {  // never, all levels from 2 px, the default
        const auto y = nets::UNetInference(*net, side).forward(x.clone());
        EXPECT_LT((y - ref).abs().max().item<double>(), 2e-5) << norm << " " << up << " phase from " << side;
      }
      // A batch-norm model in train mode differs (batch statistics): the comparison can fail.
      if (std::string(norm) == "batch") {
        net->train();
        torch::NoGradGuard no_grad;
        EXPECT_GT((net->forward(x) - ref).abs().max().item<double>(), 1e-3);
      }
    }
  // run_generator through the inference form equals generator_forward on the module.
  torch::manual_seed(0);
  Options o = small_options(1);
  BareSkinTask task(o);
  auto G = std::dynamic_pointer_cast<nets::UNetImpl>(task.generator());
  {
    torch::NoGradGuard no_grad;
    for (auto& p : G->named_parameters()) p.value().add_(torch::randn_like(p.value()) * 0.05);
  }
  G->eval();
  auto x = torch::rand({2, 3, kSize, kSize});
  Demakeup d;
  d.G = G;
  d.size = kSize;
  d.head = "residual";
  const auto plain = run_generator(d, x);
  d.G_inference = std::make_shared<nets::UNetInference>(*G);
  const auto fast = run_generator(d, x);
  EXPECT_GT((plain - x).abs().max().item<double>(), 1e-3);
  EXPECT_LT((fast - plain).abs().max().item<double>(), 1e-5);
}

}  // namespace
}  // namespace bareskin::bsn
