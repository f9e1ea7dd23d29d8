// bareskin train recon: the teacher F (ResNet-50 with light) or the student E (ResNet-18) on face samples of
// `texgen faces`, supervised by the samples' coefficients, by Deep3DFaceRecon's self-supervised terms, or both
// (recon/recon.h). docs/training.md, "Face reconstruction (F / E)"; docs/cli.md.
#include <filesystem>
#include <iostream>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "detect/face_api.h"
#include "core/shards.h"
#include "training/device.h"
#include "training/ranks.h"
#include "recon/recon.h"

namespace bareskin::cli {

namespace fs = std::filesystem;

namespace {
// --profile: "paper" is Deep3DFaceRecon's F (ResNet-50 at the samples' 256², lr 1e-4, 20k steps); "cpu" a
// ResNet-18 of width 16 at 128² that a 2-core CPU trains in minutes (docs/training.md, "Profiles").
const std::vector<Profile>& recon_profiles() {
  static const std::vector<Profile> profiles = {
      {"paper", "ResNet-50 width 64 at the samples' size, lr 1e-4, 20k steps of 8 (a GPU's hours)", {}},
      {"cpu", "ResNet-18 width 16 with light at 128², truth + landmark terms, lr 1e-3, 3000 steps of 8",
       {{"--arch", "resnet18"},
        {"--width", "16"},
        {"--gamma", "on"},
        {"--image-size", "128"},
        {"--supervision", "both"},
        {"--loss", R"({"photo": 0, "identity": 0})"},
        {"--lr", "1e-3"},
        {"--steps", "3000"}}},
  };
  return profiles;
}
}  // namespace

std::function<bool()> setup_train_recon(CLI::App& train, const Globals& globals) {
  struct Options {
    std::string data, model, output = "runs/F", arch = "resnet50", supervision = "both", input = "before", loss,
                gamma = "auto", profile;
    int width = 64, image_size = 0;
    int64_t decay_every = 0, eval_batches = 8;
    double lr = 1e-4;
    TrainerFlags t;
  };
  auto o = std::make_shared<Options>();
  o->t.steps = 20000;
  o->t.batch = 8;
  CLI::App* app = train.add_subcommand("recon", "Train the teacher F (resnet50) or the student E (resnet18): 3DMM "
                                                "coefficients and light from an aligned face");
  app->add_option("--data", o->data, "Face samples of 'texgen faces' (train/ and val/ inside)")->required();
  app->add_option("--model", o->model, "The morphable model (model.safetensors): sizes the heads")->required();
  app->add_option("-o,--output", o->output, "Run folder")->capture_default_str();
  app->add_option("--arch", o->arch, "resnet50 (the teacher F) or resnet18 (the student E)")
      ->check(CLI::IsMember({"resnet50", "resnet18", "resnet34"}))->capture_default_str();
  app->add_option("--width", o->width, "Channels of conv1/layer1 (64: torchvision; 8-16: tiny nets for tests, CPU demo)")
      ->capture_default_str()->check(CLI::Range(1, 1024));
  app->add_option("--gamma", o->gamma, "Regress the light γ: on, off, auto (on for resnet50, off otherwise)")
      ->check(CLI::IsMember({"on", "off", "auto"}))->capture_default_str();
  app->add_option("--supervision", o->supervision, "truth (the samples' coefficients), self (Deep3DFaceRecon's terms: "
                                                   "photo, landmarks, reg, gamma, identity), both")
      ->check(CLI::IsMember({"truth", "self", "both"}))->capture_default_str();
  app->add_option("--input", o->input, "The member the net sees: before (lit, no makeup) or makeup")
      ->check(CLI::IsMember({"before", "makeup"}))->capture_default_str();
  app->add_option("--image-size", o->image_size, "Train at this square size (the samples are area-resampled; 0: "
                                                 "theirs, 256²; 128 is 4× cheaper on the CPU)")->capture_default_str();
  app->add_option("--loss", o->loss, "Loss weights over the defaults, JSON (docs/training.md), e.g. '{\"identity\": 0}'");
  add_trainer_flags(*app, o->t);
  add_profile_flag(*app, o->profile, recon_profiles());
  app->add_option("--lr", o->lr, "Adam's learning rate (Deep3DFaceRecon: 1e-4)")->capture_default_str();
  app->add_option("--decay-every", o->decay_every, "Steps between ×0.2 decays (0: half the steps, as "
                                                   "Deep3DFaceRecon's 10 of 20 epochs; -1: never)")->capture_default_str();
  app->add_option("--eval-batches", o->eval_batches, "Validation batches per evaluation")->capture_default_str();
  app->footer("Examples:\n  bareskin train recon --profile cpu --data faces/ --model model.safetensors -o runs/F\n"
              "  bareskin train recon --device cuda --data faces/ --model model.safetensors -o runs/F\n"
              "docs/training.md, \"Face reconstruction (F / E)\", describes the heads, losses and metrics.");
  return [o, app, &globals] {
    if (!app->parsed()) return false;
    const nlohmann::json profile = apply_profile(*app, o->profile, recon_profiles());
    const torch::Device device = parse_device(o->t.device);
    if (!fs::exists(o->model)) throw IoError(o->model, "does not exist", "give the morphable model file (mm-build)");
    recon::ReconTaskOptions to;
    to.net.arch = o->arch;
    to.net.width = o->width;
    to.net.gamma = o->gamma == "auto" ? o->arch == "resnet50" : o->gamma == "on";
    to.net.check();
    to.loss.supervision = recon::parse_supervision(o->supervision);
    recon::from_json(json_flag(o->loss, "--loss", "{\"photo\": 1.0}"), to.loss);
    to.input = o->input;
    to.lr = o->lr;
    to.schedule.step_every = o->decay_every > 0 ? o->decay_every : o->decay_every == 0 ? std::max<int64_t>(1, o->t.steps / 2) : 0;
    if (to.schedule.step_every == 0) to.schedule.kind = "constant";
    const recon::FaceModel model = recon::FaceModel::load(o->model);
    const auto [train_dir, val_dir] = shards::find_splits(o->data, "give the folder 'bareskin texgen faces' wrote");
    data::LoaderOptions lo;
    lo.dataset = train_dir;
    lo.required = {o->input + ".png", "json"};
    lo.batch_size = o->t.batch;
    lo.seed = o->t.seed;
    data::ShardLoader loader(dist::this_rank(lo));
    {
      // The image size from the first sample; the nets take any size, the face model renders at it.
      data::LoaderOptions peek = lo;
      peek.batch_size = 1;
      peek.shuffle_buffer = 0;
      peek.decode_threads = 1;
      const data::Batch b = data::ShardLoader(peek).next();
      to.image_size = b.at(o->input).size(3);
      if (b.at(o->input).size(2) != to.image_size) throw InvalidInput(train_dir, "the samples are not square", "");
      if (o->image_size > 0) to.image_size = o->image_size;
    }
    std::unique_ptr<data::ShardLoader> val;
    if (!val_dir.empty()) {
      data::LoaderOptions vo = lo;
      vo.dataset = val_dir;
      vo.shuffle_buffer = 0;
      val = std::make_unique<data::ShardLoader>(vo);
    }
    std::shared_ptr<detect::FaceRecognitionNet> identity;
    if (to.loss.identity > 0 && to.loss.supervision != recon::Supervision::Truth) {
      identity = std::make_shared<detect::FaceRecognitionNet>(detect::default_face_api_folder());
      (*identity)->to(device);
      (*identity)->eval();
      for (auto& p : (*identity)->parameters()) p.requires_grad_(false);
    }
    train::seed_everything(o->t.seed);
    recon::ReconTask task(to, model, identity, device);
    train::TrainerOptions topt;
    topt.run_dir = o->output;
    topt.steps = o->t.steps;
    topt.log_every = o->t.log_every;
    topt.checkpoint_every = o->t.checkpoint_every;
    topt.eval_every = val ? o->t.eval_every : 0;
    topt.eval_batches = o->eval_batches;
    topt.sample_every = o->t.sample_every;
    topt.resume = o->t.resume;
    topt.device = device;
    topt.progress = !globals.quiet();
    topt.config = {{"net", to.net}, {"loss", to.loss}, {"input", to.input}, {"image_size", to.image_size},
                   {"model", fs::absolute(o->model).string()},
                   {"layout", {{"id", model.layout().id}, {"exp", model.layout().exp}, {"app", model.layout().app}}},
                   {"data", o->data}, {"batch", o->t.batch}, {"lr", o->lr}, {"decay_every", o->decay_every},
                   {"seed", o->t.seed}, {"steps", o->t.steps}, {"log_every", o->t.log_every},
                   {"checkpoint_every", o->t.checkpoint_every}, {"eval_every", topt.eval_every},
                   {"eval_batches", o->eval_batches}, {"sample_every", o->t.sample_every}, {"device", o->t.device}};
    topt.config["profile"] = profile;
    topt.resumable_keys.push_back("profile");  // runs made before profiles existed have none
    train::Trainer trainer(topt, task, loader, val.get());
    const train::TrainResult result = trainer.run();
    if (!globals.quiet()) {
      for (const auto& [k, v] : result.last_eval) std::cerr << "val " << k << " " << v << "\n";
      std::cerr << "wrote " << o->output << " (" << task.module_name() << ", " << result.steps << " steps)\n";
    }
    return true;
  };
}

}  // namespace bareskin::cli
