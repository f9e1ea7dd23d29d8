// The face model layer and the reconstruction networks, against truth and independent paths:
// - FaceModel against the geometry side (morphable/coefficients.h's posed_mesh + render/shade.h's render_frame, its
//   own projection, normals, UV lookup and shading) on a model file both read;
// - a loss's gradient against central differences in double;
// - the loss falls on a fixed batch; supervised training recovers coefficients on a tiny set.
#include <gtest/gtest.h>

#include <filesystem>
#include <numeric>
#include <random>

#include "core/error.h"
#include "core/test_options.h"
#include "recon/face_model.h"
#include "recon/recon.h"
#include "recon/train_recon.h"
#include "training/checkpoint.h"
#include "training/run_flags.h"
#include "training/ssim.h"
#include "training/trainer.h"

#ifdef BARESKIN_RECON_ORACLE
#include "morphable/coefficients.h"
#include "morphable/model.h"
#include "render/shade.h"
#include "recon/recon_photo.h"
#endif

namespace bareskin::recon {
namespace {

namespace fs = std::filesystem;

// Folders under the system temp dir, removed when the test program ends.
std::vector<fs::path>& temp_dirs() {
  static std::vector<fs::path> dirs;
  return dirs;
}
struct RemoveTempDirs : ::testing::Environment {
  void TearDown() override {
    std::error_code ec;
    for (const fs::path& d : temp_dirs()) fs::remove_all(d, ec);
  }
};
const auto* const kRemoveTempDirs = ::testing::AddGlobalTestEnvironment(new RemoveTempDirs);

std::string temp_dir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("bareskin_recon_test_" + name + "_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  temp_dirs().push_back(dir);
  return dir.string();
}

const std::string& toy_model_path() {
  static const std::string path = [] {
    const std::string p = temp_dir("model") + "/toy.safetensors";
    save_toy_model(p, {});
    return p;
  }();
  return path;
}

// `count` faces of the toy model rendered at 64² into a fresh folder, and a loader over them in their order.
data::LoaderOptions rendered_loader(const std::string& name, int64_t count, int64_t batch, uint64_t seed = 1) {
  const std::string dir = temp_dir(name);
  RenderedFacesOptions ro;
  ro.count = count;
  ro.size = 64;
  ro.seed = seed;
  write_rendered_faces(dir, FaceModel::load(toy_model_path()), ro);
  data::LoaderOptions lo;
  lo.dataset = dir;
  lo.batch_size = batch;
  lo.shuffle_buffer = 0;
  lo.decode_threads = 1;
  return lo;
}

// Random coefficients of the model's layout: α, β, δ ~ N(0, 1) × scale, a turned pose, light near the default.
torch::Tensor random_coefficients(const CoefficientLayout& l, int64_t B, uint64_t seed, double scale = 1.0) {
  torch::manual_seed(seed);
  torch::Tensor c = torch::zeros({B, l.size()}, torch::kDouble);
  c.narrow(1, 0, l.id + l.exp + l.app).normal_(0, scale);
  c.narrow(1, l.rotation_offset(), 3).uniform_(-0.25, 0.25);
  c.narrow(1, l.translation_offset(), 3).uniform_(-8, 8);
  if (l.gamma) {
    torch::Tensor g = c.narrow(1, l.gamma_offset(), 27);
    g.normal_(0, 0.08);
    for (int k = 0; k < 3; ++k) g.select(1, 9 * k).add_(0.8);
  }
  return c;
}

TEST(FaceModel, SplitJoinAndCoefficientFiles) {
  const FaceModel m = FaceModel::load(toy_model_path());
  const CoefficientLayout l = m.layout();
  EXPECT_EQ(l.id, 6);
  EXPECT_EQ(l.exp, 4);
  EXPECT_EQ(l.app, 3);
  EXPECT_EQ(l.size(), 6 + 4 + 3 + 6 + 27);
  const torch::Tensor c = random_coefficients(l, 2, 3).to(torch::kFloat);
  EXPECT_TRUE(torch::equal(m.join(m.split(c)), c));
  const nlohmann::json j = coefficients_to_json(c[1], l);
  EXPECT_TRUE(torch::allclose(coefficients_from_json(j, l), c[1]));
  EXPECT_EQ(j.at("gamma").size(), 27u);
  // The model is linear: the difference of two shapes is the displacement of the coefficients' difference.
  const FaceCoefficients a = m.split(c.narrow(0, 0, 1)), b = m.split(c.narrow(0, 1, 1));
  EXPECT_TRUE(torch::allclose(m.shape(a.alpha, a.beta) - m.shape(b.alpha, b.beta),
                              m.displacement(a.alpha - b.alpha, a.beta - b.beta), 1e-4, 1e-4));
  // A shorter file pads with zeros and the ambient light; a longer one is refused naming the file.
  const torch::Tensor padded = coefficients_from_json({{"alpha", {1.0}}}, l);
  EXPECT_EQ(padded[0].item<float>(), 1.0f);
  EXPECT_EQ(padded.narrow(0, 1, l.size() - 28).abs().sum().item<float>(), 0.0f);
  EXPECT_FLOAT_EQ(padded[l.gamma_offset() + 9].item<float>(), 0.8f);
  try {
    coefficients_from_json({{"beta", std::vector<double>(9, 0.0)}}, l, "x.json");
    FAIL() << "a longer beta was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("x.json"), std::string::npos);
  }
  EXPECT_THROW(m.split(torch::zeros({2, l.size() + 1})), InvalidInput);
  EXPECT_THROW(FaceModel::load(temp_dir("missing") + "/none.safetensors"), IoError);
}


// The options through core/json_options.h: non-default values round-trip, unknown keys and bad values are refused.
TEST(ReconOptions, RoundTripAndRefuseUnknownKeys) {
  testing::expect_options_json<ReconNetOptions>(
      {{"arch", "resnet18"}, {"width", 16}, {"gamma", false}, {"translation_scale", 5.0}, {"pool_grid", 2}});
  testing::expect_options_json<LossOptions>({{"supervision", "self"}, {"truth", 0.5}, {"w_alpha", 2.0},
                                             {"rotation_unit", 0.1}, {"shape", 3.0}, {"photo", 1.0}, {"identity", 0.0}});
  EXPECT_THROW(nlohmann::json({{"arch", "vgg"}}).get<ReconNetOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"width", 64.5}}).get<ReconNetOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"pool_grid", 0}}).get<ReconNetOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"photo", -1}}).get<LossOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"supervision", "some"}}).get<LossOptions>(), InvalidInput);
  EXPECT_THROW(nlohmann::json({{"supervision", 1}}).get<LossOptions>(), InvalidInput);
}

// The Torch side's options check their own fields (core/test_options.h) and the functions that take them check first:
// the trainer's intervals (a log interval of 0 divided by zero), the loader, SSIM, the recon task and run, the photo
// reconstruction. texgen/options_check_test.cc has the geometry side's.
TEST(ReconOptions, CheckRefusesBadValues) {
  using testing::expect_check_refuses;
  train::TrainerOptions trainer;
  trainer.run_dir = "run";
  expect_check_refuses(trainer, [](auto& o) { o.log_every = 0; }, "--log-every");
  expect_check_refuses(trainer, [](auto& o) { o.eval_batches = 0; }, "eval_batches");
  expect_check_refuses(trainer, [](auto& o) { o.run_dir.clear(); }, "run folder");
  expect_check_refuses(train::RunFlags{}, [](auto& o) { o.batch = 0; }, "--batch");
  expect_check_refuses(train::RunFlags{}, [](auto& o) { o.sample_every = -1; }, "--sample-every");
  expect_check_refuses(data::LoaderOptions{}, [](auto& o) { o.decode_threads = 0; }, "decode threads");
  expect_check_refuses(data::LoaderOptions{}, [](auto& o) { o.augment.flip_probability = 2; }, "flip");  // nested
  expect_check_refuses(losses::SsimOptions{}, [](auto& o) { o.window = 10; }, "window 10");
  expect_check_refuses(ReconTaskOptions{}, [](auto& o) { o.input = "bare"; }, "--input");
  expect_check_refuses(ReconTaskOptions{}, [](auto& o) { o.net.width = 0; }, "width");  // nested
  expect_check_refuses(ConfidenceOptions{}, [](auto& o) { o.psnr_db = -3; }, "PSNR");
  expect_check_refuses(RenderedFacesOptions{}, [](auto& o) { o.split = "dev"; }, "split 'dev'");
  expect_check_refuses(ToyModelOptions{}, [](auto& o) { o.id = 0; }, "identity");
  TrainReconOptions run;
  run.data = "faces", run.model = "model.safetensors";
  expect_check_refuses(run, [](auto& o) { o.gamma = "maybe"; }, "--gamma");
  expect_check_refuses(run, [](auto& o) { o.eval_batches = 0; }, "--eval-batches");
  expect_check_refuses(run, [](auto& o) { o.trainer.log_every = 0; }, "--log-every");  // nested

  // First, before anything is read: the dataset, the model and the run folder do not exist.
  data::LoaderOptions loader;
  loader.dataset = temp_dir("check") + "/no_such_dataset";
  loader.shuffle_buffer = -1;
  EXPECT_THROW(data::ShardLoader{loader}, InvalidInput);
  run.data = loader.dataset, run.model = loader.dataset + ".safetensors", run.output = temp_dir("check") + "/run";
  run.trainer.log_every = 0;
  EXPECT_THROW(train_recon(run), InvalidInput);
  EXPECT_FALSE(fs::exists(run.output + "/config.json"));
  const torch::Tensor a = torch::rand({1, 3, 16, 16});
  losses::SsimOptions ssim;
  ssim.k2 = 0;
  EXPECT_THROW(losses::ssim(a, a, ssim), InvalidInput);
}

// The summed terms' gradient (the truth and shape terms, photometric over an interior skin region, landmarks,
// regularisation, γ) in double against central differences, for one coefficient of every group.
TEST(ReconLosses, GradientMatchesFiniteDifferences) {
  const FaceModel m = FaceModel::load(toy_model_path()).to(torch::kCPU, torch::kDouble);
  const int64_t size = 48;
  const CoefficientLayout l = m.layout();
  const torch::Tensor truth = random_coefficients(l, 2, 21, 0.7);
  ReconTargets t;
  t.image = linear_to_srgb(m.render(truth, canonical_camera(int(size))).colour.clamp(0, 1));
  // Skin: a disc well inside the face, so that no pixel of it changes coverage under the small steps.
  const torch::Tensor yy = torch::arange(size, torch::kDouble).view({-1, 1}) + 0.5 - size / 2.0;
  const torch::Tensor xx = torch::arange(size, torch::kDouble).view({1, -1}) + 0.5 - size / 2.0;
  t.skin = ((xx * xx + yy * yy) < 8.0 * 8.0).to(torch::kDouble).expand({2, 1, size, size}).contiguous();
  t.landmarks = m.landmarks(m.split(truth), canonical_camera(int(size)));
  t.landmark_weight = torch::ones({2, 68}, torch::kDouble);
  t.truth = truth;
  t.has_truth = torch::ones({2}, torch::kDouble);
  LossOptions o;
  o.supervision = Supervision::Both;
  o.identity = 0;
  o.reg = 1e-2;  // large enough to matter in the sum
  o.shape = 0.5;
  const torch::Tensor x0 = random_coefficients(l, 2, 22, 0.7);
  // Start near the truth so the disc stays on the face.
  const torch::Tensor start = truth + 0.1 * (x0 - truth);
  const auto total = [&](const torch::Tensor& x) {
    torch::Tensor sum = torch::zeros({}, torch::kDouble);
    for (const auto& [name, v] : recon_losses(m, x, t, o, nullptr, size)) sum = sum + v;
    return sum;
  };
  torch::Tensor x = start.clone().requires_grad_(true);
  const torch::Tensor loss = total(x);
  ASSERT_EQ(recon_losses(m, x, t, o, nullptr, size).size(), 6u);  // truth, shape, photo, landmark, reg, gamma
  loss.backward();
  const torch::Tensor grad = x.grad();
  const int64_t probes[] = {0, l.id, l.id + l.exp, l.rotation_offset() + 1, l.translation_offset(), l.gamma_offset() + 2,
                            l.gamma_offset() + 9};
  for (int64_t k : probes) {
    const double h = 1e-5;
    torch::Tensor xp = start.clone(), xm = start.clone();
    xp[1][k] += h;
    xm[1][k] -= h;
    const double fd = (total(xp).item<double>() - total(xm).item<double>()) / (2 * h);
    const double g = grad[1][k].item<double>();
    std::printf("coefficient %lld: autograd %.6g, differences %.6g\n", static_cast<long long>(k), g, fd);
    EXPECT_NEAR(g, fd, 1e-4 + 2e-3 * std::abs(fd)) << "coefficient " << k;
    EXPECT_GT(std::abs(fd), 1e-6) << "coefficient " << k << " has no effect: the probe tests nothing";
  }
}

// Tiny F on rendered faces: the self-supervised loss falls on a fixed batch.
TEST(ReconTask, SelfSupervisedLossFallsOnAFixedBatch) {
  const FaceModel m = FaceModel::load(toy_model_path());
  data::ShardLoader loader(rendered_loader("fixed", 4, 4));
  const data::Batch batch = loader.next();
  train::seed_everything(3);
  ReconTaskOptions to;
  to.net.arch = "resnet18";
  to.net.width = 8;
  to.loss.supervision = Supervision::Self;
  to.loss.identity = 0;
  to.image_size = 64;
  ReconTask task(to, m, nullptr, torch::kCPU);
  torch::optim::Adam adam(task.net()->parameters(), torch::optim::AdamOptions(1e-3));
  const auto sum = [](const train::Losses& L) {
    torch::Tensor s = torch::zeros({});
    for (const auto& [k, v] : L) s = s + v;
    return s;
  };
  task.net()->eval();  // batch norm in inference mode: the same function each step
  double first = 0, last = 0;
  for (int step = 0; step < 40; ++step) {
    adam.zero_grad();
    const torch::Tensor loss = sum(task.loss(0, batch));
    if (step == 0) first = loss.item<double>();
    last = loss.item<double>();
    loss.backward();
    adam.step();
  }
  std::printf("loss %.4f -> %.4f\n", first, last);
  EXPECT_LT(last, 0.5 * first) << "first " << first << " last " << last;
}

// The colour jitter keeps photo and truth a pair: the jittered photo is, on the face, the model's render under the
// sample's γ scaled by the same gains (the oracle), and no jitter (s 0) changes nothing.
TEST(ReconData, ColourJitterKeepsPhotoAndLightAPair) {
  const FaceModel m = FaceModel::load(toy_model_path());
  data::LoaderOptions lo = rendered_loader("jitter", 3, 1);
  lo.transform = [](data::Example& e, uint64_t seed) {
    e.tensors["plain"] = e.tensors.at("before").clone();
    e.meta["plain_gamma"] = e.meta["coefficients"]["gamma"];
    jitter_colour(e, "before", 0, seed);
    EXPECT_TRUE(torch::equal(e.tensors.at("before"), e.tensors.at("plain")));
    jitter_colour(e, "before", 0.3, seed);
  };
  data::ShardLoader loader(lo);
  const CoefficientLayout l = m.layout(true);
  for (int i = 0; i < 3; ++i) {
    const data::Batch b = loader.next();
    const ReconTargets t = targets_from_batch(b, m);
    const FaceRender r = m.render(t.truth, canonical_camera(64));
    const torch::Tensor plain = torch::tensor(b.meta[0]["plain_gamma"].get<std::vector<double>>()).view({3, 9});
    const torch::Tensor gain = t.truth[0].narrow(0, l.gamma_offset(), 27).view({3, 9}).to(torch::kDouble) / plain;
    EXPECT_LT((gain - gain.select(1, 0).unsqueeze(1)).abs().max().item<double>(), 1e-5) << "one gain per channel";
    EXPECT_GT((gain.select(1, 0) - 1).abs().max().item<double>(), 0.01) << "the jitter changed nothing";
    EXPECT_LT(gain.max().item<double>(), std::exp(0.3) + 1e-5);
    // On the face, away from its outline and where the jitter did not clip: the render under the scaled γ.
    const torch::Tensor inside = (r.mask > 0.999) & (linear_to_srgb(r.colour) < 0.99) & (r.colour > 0);
    const torch::Tensor want = linear_to_srgb(r.colour.clamp(0, 1)).masked_select(inside);
    const torch::Tensor got = b.at("before").unsqueeze(0).masked_select(inside);
    ASSERT_GT(want.numel(), 500);
    EXPECT_LT((got - want).abs().max().item<double>(), 4.0 / 255) << "sample " << i;  // PNG's 8 bits, twice
    EXPECT_GT((b.at("plain") - b.at("before")).abs().max().item<double>(), 0.02);
  }
}

// Heads on a pooling grid read every cell of layer4 and start, like the global average's, at the mean face under the
// ambient light.
TEST(ReconNet, PoolGridHeadsStartAtTheMeanFace) {
  const FaceModel m = FaceModel::load(toy_model_path());
  ReconNetOptions o;
  o.arch = "resnet18";
  o.width = 8;
  torch::manual_seed(3);
  ReconNet global(o, m.layout());
  o.pool_grid = 2;
  ReconNet grid(o, m.layout());
  const torch::Tensor image = torch::rand({2, 3, 64, 64});
  global->eval();
  grid->eval();
  EXPECT_TRUE(torch::equal(grid->forward(image), global->forward(image)));
  const auto params = grid->named_parameters();
  EXPECT_EQ(params["alpha.weight"].size(1), 4 * params["backbone.layer4.1.bn2.weight"].size(0));
}

// Supervised training on the Trainer recovers the coefficients of a tiny rendered set (error in σ well below that of
// the mean face), and the run folder holds a checkpoint that loads into a fresh net.
TEST(ReconTask, SupervisedTrainingRecoversCoefficients) {
  const FaceModel m = FaceModel::load(toy_model_path());
  data::ShardLoader loader(rendered_loader("tiny", 8, 8, 5));
  train::seed_everything(7);
  ReconTaskOptions to;
  to.net.arch = "resnet18";
  to.net.width = 8;
  to.loss.supervision = Supervision::Truth;
  to.lr = 3e-3;
  to.schedule.step_every = 1000;
  to.image_size = 64;
  ReconTask task(to, m, nullptr, torch::kCPU);
  const data::Batch batch = loader.next();
  const ReconTargets t = targets_from_batch(batch, m);
  task.net()->eval();
  const auto before = recon_metrics(m, task.net()->forward(t.image), t, 64);
  train::TrainerOptions opt;
  opt.run_dir = temp_dir("run");
  opt.steps = 150;
  opt.log_every = 50;
  opt.checkpoint_every = 150;
  opt.eval_every = 0;
  opt.sample_every = 0;
  opt.progress = false;
  train::Trainer trainer(opt, task, loader, nullptr);
  trainer.run();
  task.net()->eval();
  const auto after = recon_metrics(m, task.net()->forward(t.image), t, 64);
  const auto mean = [](const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0) / v.size(); };
  for (const char* k : {"alpha_sigma", "shape_mm", "landmark_px", "gamma_rmse", "skin_psnr"}) {
    std::printf("%s: %.3f -> %.3f\n", k, mean(before.at(k)), mean(after.at(k)));
  }
  EXPECT_LT(mean(after.at("alpha_sigma")), 0.3 * mean(before.at("alpha_sigma")));
  EXPECT_LT(mean(after.at("shape_mm")), 0.3 * mean(before.at("shape_mm")));
  EXPECT_LT(mean(after.at("landmark_px")), 0.3 * mean(before.at("landmark_px")));
  EXPECT_LT(mean(after.at("gamma_rmse")), 0.5 * mean(before.at("gamma_rmse")));
  ReconNet fresh(to.net, m.layout());
  train::load_module_weights(train::checkpoint_path(opt.run_dir), "F", *fresh);
  fresh->eval();
  EXPECT_TRUE(torch::allclose(fresh->forward(t.image), task.net()->forward(t.image), 1e-5, 1e-5));
}

#ifdef BARESKIN_RECON_ORACLE
// The layer against the geometry side, in double: the same pixels covered, colour and albedo to < 1e-3, landmarks to
// < 1e-3 px, for posed, lit faces with seams in their UVs.
TEST(FaceModel, AgreesWithRenderFrame) {
  const FaceModel m = FaceModel::load(toy_model_path()).to(torch::kCPU, torch::kDouble);
  const MorphableModel geo = read_model(toy_model_path());
  const int size = 96;
  const Camera cam = canonical_camera(size);
  const torch::Tensor c = random_coefficients(m.layout(), 3, 11);
  const FaceRender r = m.render(c, cam);
  ASSERT_EQ(r.colour.sizes(), torch::IntArrayRef({3, 3, size, size}));
  for (int64_t b = 0; b < 3; ++b) {
    const Coefficients gc = to_coefficients(c[b], m.layout());
    const Mesh mesh = posed_mesh(geo, gc);
    const Image tex = appearance_image(geo, gc);
    ShadeOptions so;
    so.texture = &tex;
    so.gamma = *gc.gamma;
    const Frame f = render_frame(mesh, cam, so);
    int64_t covered = 0, mismatched = 0;
    double colour_err = 0, albedo_err = 0;
    for (int y = 0; y < size; ++y) {
      for (int x = 0; x < size; ++x) {
        const bool ours = r.mask[b][0][y][x].item<double>() > 0.5, theirs = f.mask.at(x, y, 0) > 0.5;
        if (ours != theirs) ++mismatched;
        if (!ours || !theirs) continue;
        ++covered;
        for (int k = 0; k < 3; ++k) {
          colour_err = std::max(colour_err, std::abs(r.colour[b][k][y][x].item<double>() - f.colour.at(x, y, k)));
          albedo_err = std::max(albedo_err, std::abs(r.albedo[b][k][y][x].item<double>() - f.albedo.at(x, y, k)));
        }
      }
    }
    EXPECT_GT(covered, size * size / 6) << "face " << b;
    EXPECT_EQ(mismatched, 0) << "face " << b;
    EXPECT_LT(colour_err, 1e-3) << "face " << b;
    EXPECT_LT(albedo_err, 1e-3) << "face " << b;
    double lm_err = 0;
    for (int k = 0; k < 68; ++k) {
      const Eigen::Vector3d p = cam.project(mesh.V.row(geo.landmark_vertices[size_t(k)]).transpose());
      lm_err = std::max({lm_err, std::abs(r.landmarks[b][k][0].item<double>() - p.x()),
                         std::abs(r.landmarks[b][k][1].item<double>() - p.y())});
    }
    EXPECT_LT(lm_err, 1e-3) << "face " << b;
    // Not a vacuous agreement: the light and the albedo both vary over the face.
    EXPECT_GT((r.colour[b] - r.albedo[b]).abs().max().item<double>(), 0.05);
  }
}
#endif

}  // namespace
}  // namespace bareskin::recon
