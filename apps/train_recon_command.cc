// bareskin train recon: the teacher F (ResNet-50 with light) or the student E (ResNet-18) on face samples of
// `texgen faces`, supervised by the samples' coefficients, by Deep3DFaceRecon's self-supervised terms, or both
// (recon/recon.h). docs/training.md, "Face reconstruction (F / E)"; docs/cli.md.
#include <iostream>

#include "apps/cli.h"
#include "recon/train_recon.h"

namespace bareskin::cli {

namespace {
// --profile: "paper" is Deep3DFaceRecon's F (ResNet-50 at the samples' 256², lr 1e-4, 20k steps); "cpu" a
// ResNet-18 of width 16 at 128² that a 2-core CPU trains in minutes (docs/training.md, "Profiles").
const std::vector<Profile>& recon_profiles() {
  static const std::vector<Profile> profiles = {
      {"paper", "ResNet-50 width 64 at the samples' size, lr 1e-4, 20k steps of 8 (a GPU's hours)", {}},
      {"cpu", "ResNet-18 width 16 with light at 128², truth (identity α at weight 30) + landmark terms, lr 1e-3, 6000 "
              "steps of 8",
       {{"--arch", "resnet18"},
        {"--width", "16"},
        {"--gamma", "on"},
        {"--image-size", "128"},
        {"--supervision", "both"},
        // α at 30: identity barely shows in a 128² photo of this model (0.7 px of landmark motion), and at the truth
        // term's equal group weights F stayed near the mean face (0.91x its shape error at 3000 steps; α at 10: 0.80x,
        // 30: 0.78x, 100: 0.79x with landmarks 1.4 -> 1.7 px). 6000 steps: 0.68x (bench/BENCHMARKS.md, "CPU profile").
        {"--loss", R"({"photo": 0, "identity": 0, "w_alpha": 30})"},
        {"--lr", "1e-3"},
        {"--steps", "6000"}}},
  };
  return profiles;
}
}  // namespace

std::function<bool()> setup_train_recon(CLI::App& train, const Globals& globals) {
  struct Options {
    recon::TrainReconOptions run;
    std::string loss, profile;
  };
  auto o = std::make_shared<Options>();
  CLI::App* app = train.add_subcommand("recon", "Train the teacher F (resnet50) or the student E (resnet18): 3DMM "
                                                "coefficients and light from an aligned face");
  app->add_option("--data", o->run.data, "Face samples of 'texgen faces' (train/ and val/ inside)")->required();
  app->add_option("--model", o->run.model, "The morphable model (model.safetensors): sizes the heads")->required();
  app->add_option("-o,--output", o->run.output, "Run folder")->capture_default_str();
  app->add_option("--arch", o->run.arch, "resnet50 (the teacher F) or resnet18 (the student E)")
      ->check(CLI::IsMember({"resnet50", "resnet18", "resnet34"}))->capture_default_str();
  app->add_option("--width", o->run.width, "Channels of conv1/layer1 (64: torchvision; 8-16: tiny nets for tests, CPU demo)")
      ->capture_default_str()->check(CLI::Range(1, 1024));
  app->add_option("--pool-grid", o->run.pool_grid, "The heads read layer4 averaged over N × N cells, flattened (1: the "
                  "global average of torchvision and Deep3DFaceRecon; 2-4 keep where features are)")
      ->capture_default_str()->check(CLI::Range(1, 16));
  app->add_option("--gamma", o->run.gamma, "Regress the light γ: on, off, auto (on for resnet50, off otherwise)")
      ->check(CLI::IsMember({"on", "off", "auto"}))->capture_default_str();
  app->add_option("--supervision", o->run.supervision, "truth (the samples' coefficients), self (Deep3DFaceRecon's terms: "
                                                   "photo, landmarks, reg, gamma, identity), both")
      ->check(CLI::IsMember({"truth", "self", "both"}))->capture_default_str();
  app->add_option("--input", o->run.input, "The member the net sees: before (lit, no makeup) or makeup")
      ->check(CLI::IsMember({"before", "makeup"}))->capture_default_str();
  app->add_option("--image-size", o->run.image_size, "Train at this square size (the samples are area-resampled; 0: "
                                                 "theirs, 256²; 128 is 4× cheaper on the CPU)")->capture_default_str();
  app->add_option("--loss", o->loss, "Loss weights over the defaults, JSON (docs/training.md), e.g. '{\"identity\": 0}'");
  add_trainer_flags(*app, o->run.trainer);
  add_profile_flag(*app, o->profile, recon_profiles());
  app->add_option("--lr", o->run.lr, "Adam's learning rate (Deep3DFaceRecon: 1e-4)")->capture_default_str();
  add_clip_grad_norm_flag(*app, o->run.clip_grad_norm);
  app->add_option("--colour-jitter", o->run.colour_jitter, "Each training photo's channels scaled by exp(s·u), u uniform "
                  "in [-1, 1], in linear light, with the true light γ scaled alike, so F cannot tell a trained identity "
                  "by its skin's colour (0: off)")->capture_default_str();
  app->add_option("--decay-every", o->run.decay_every, "Steps between ×0.2 decays (0: half the steps, as "
                                                   "Deep3DFaceRecon's 10 of 20 epochs; -1: never)")->capture_default_str();
  app->add_option("--eval-batches", o->run.eval_batches, "Validation batches per evaluation")->capture_default_str();
  app->footer("Examples:\n  bareskin train recon --profile cpu --data faces/ --model model.safetensors -o runs/F\n"
              "  bareskin train recon --device cuda --data faces/ --model model.safetensors -o runs/F\n"
              "docs/training.md, \"Face reconstruction (F / E)\", describes the heads, losses and metrics.");
  return [o, app, &globals] {
    if (!app->parsed()) return false;
    const nlohmann::json profile = apply_profile(*app, o->profile, recon_profiles());
    recon::TrainReconOptions run = o->run;
    run.loss = json_flag(o->loss, "--loss", "{\"photo\": 1.0}");
    run.progress = !globals.quiet();
    run.profile = profile;
    const recon::TrainReconResult result = recon::train_recon(run);
    if (!globals.quiet()) {
      for (const auto& [k, v] : result.last_eval) std::cerr << "val " << k << " " << v << "\n";
      std::cerr << "wrote " << o->run.output << " (" << result.module << ", " << result.steps << " steps)\n";
    }
    return true;
  };
}

}  // namespace bareskin::cli
