// bareskin train bareskin: BareSkinNet's two stages (bareskinnet/bareskinnet.h) on `texgen faces` samples, with the
// teacher F of `bareskin train recon`. docs/training.md, "BareSkinNet"; docs/cli.md.
#include "apps/cli.h"
#include "apps/detector.h"
#include "bareskinnet/train_bareskin.h"

namespace bareskin::cli {

namespace {
// --profile: "paper" keeps the paper's sizes and recipe (the defaults of every flag); "cpu" is what a 2-core CPU
// trains in minutes to hours and still learns its task (docs/training.md, "Profiles", gives the chart it was chosen
// from).
const std::vector<Profile>& bareskin_profiles() {
  static const std::vector<Profile> profiles = {
      {"paper", "G ngf 64 at 256², 10k + 30k steps of 4, lr 2e-5 (a GPU's days)", {}},
      {"cpu", "G ngf 16 with the affine head at 128², D ndf 16, 1500 + 300 steps of 8, lr 2e-4, the bare target, LPIPS "
              "on face-api's net; stage 2 through F itself (E width 16 with --recon E), L_diff up to a gain and "
              "L_light at 20; half the samples' makeup painted over in colours of any hue",
       {{"--size", "128"},
        {"--head", "affine"},
        {"--target", "bare"},
        {"--g-options", R"({"ngf": 16})"},
        {"--d-options", R"({"ndf": 16, "n_layers": 2})"},
        {"--student-options", R"({"width": 16})"},
        {"--lpips", "facenet"},
        {"--lr-g", "2e-4"},
        {"--lr-d", "2e-4"},
        {"--ema-g", "0.99"},
        {"--batch", "8"},
        {"--steps1", "1500"},
        {"--steps2", "300"},
        // Stage 2 pulls G towards the unlit render of the 3DMM fit of its output. Through the student E, which starts
        // untrained, it only cost G (ablation rows f, g); through the trained F (row d) it lifts the albedo F reads
        // from G's output. At the paper's 100 it undid stage 1 (demo world: 24.82 → 21.54 dB in 60 steps); at 20,
        // through F: albedo +1.9 dB for G −0.6 dB, better on both than E at 10 (bench/BENCHMARKS.md, "CPU profile").
        {"--recon", "F"},
        {"--loss-weights", R"({"w_diff": 20, "w_light": 20})"},
        // The 3DMM's albedo space, built from few subjects, does not span every skin tone: with L_diff up to a gain
        // per image and channel, stage 2 lifts G on the held-out skin (+0.2 dB over stage 1 instead of −0.3) and on
        // every skin-tone group, for a smaller lift of F's albedo (+2.3 dB instead of +2.8; bench/BENCHMARKS.md).
        {"--diff-gain", "true"},
        // The held-out makeup family's saturated, opaque colours lie outside the world's palettes: painting half the
        // samples' makeup over in colours of any hue lifts G there by 1.1–1.2 dB (three seeds) for up to 0.3 dB on
        // the families it was trained on (bench/BENCHMARKS.md, "CPU profile").
        {"--makeup-paint", "0.5"}}},
  };
  return profiles;
}
}  // namespace

std::function<void()> setup_train_bareskin(CLI::App& train, const Globals& globals) {
  struct Options {
    bsn::TrainBareskinOptions run;
    std::string g, d, student, weights, profile;
  };
  auto o = std::make_shared<Options>();
  CLI::App* app = train.add_subcommand("bareskin", "Train BareSkinNet: stage 1 (G alone), stage 2 (G + E with the frozen teacher F)");
  app->add_option("--data", o->run.data, "Face samples of 'texgen faces' (train/ and val/ inside)")->required();
  app->add_option("--teacher", o->run.teacher, "The teacher F: a 'bareskin train recon' run folder (needed by stage 2)");
  app->add_option("--model", o->run.model, "The morphable model F was trained with (model.safetensors; needed by stage 2)");
  app->add_option("-o,--output", o->run.output, "Run folder (stage1/ and stage2/ inside)")->capture_default_str();
  app->add_option("--steps1", o->run.steps1, "Stage-1 iterations (the paper: 10000)")->capture_default_str()
      ->check(CLI::Range(1, 1000000000));
  app->add_option("--steps2", o->run.steps2, "Stage-2 iterations (the paper: 30000; 0: stage 1 only)")
      ->capture_default_str()->check(CLI::Range(0, 1000000000));
  app->add_option("--size", o->run.task.size, "Training resolution (a power of two; the samples are area-resized)")->capture_default_str();
  app->add_option("--target", o->run.task.target, "G's supervision: before (the paper) or bare (the albedo truth)")
      ->check(CLI::IsMember({"before", "bare"}))->capture_default_str();
  app->add_option("--ablation", o->run.ablation, "A row of the paper's Fig. 7: b (L1+GAN), c (+LPIPS), d (+frozen F), "
                  "e (+fine-tuned F), f (+E without L_light), g (full)")->check(CLI::IsMember({"b", "c", "d", "e", "f", "g"}));
  app->add_option("--recon", o->run.task.recon, "What reconstructs G's output in stage 2: E (the student, the paper) "
                  "or F (the frozen teacher itself, gradients through it)")
      ->check(CLI::IsMember({"E", "F"}))->capture_default_str();
  app->add_option("--head", o->run.task.head, "How G's image comes from its U-Net: residual (input + Δ), affine (input · "
                  "gain + offset per pixel) or image (the paper); residual and affine start as the identity")
      ->check(CLI::IsMember({"residual", "affine", "image"}))->capture_default_str();
  app->add_option("--lpips", o->run.task.lpips_trunk, "LPIPS trunk: vgg16-random or facenet (cheap on the CPU)")
      ->check(CLI::IsMember({"vgg16-random", "facenet"}))->capture_default_str();
  app->add_option("--g-options", o->g, "G (unet256) options over the defaults, JSON, e.g. '{\"ngf\": 16}'");
  app->add_option("--d-options", o->d, "D (patchgan) options, JSON");
  app->add_option("--student-options", o->student, "E options (recon net), JSON, e.g. '{\"width\": 16}'");
  app->add_option("--lr-g", o->run.task.lr_g, "G's learning rate (the paper: 2e-5)")->capture_default_str();
  app->add_option("--lr-e", o->run.task.lr_e, "E's learning rate (the paper: 1e-4)")->capture_default_str();
  app->add_option("--lr-d", o->run.task.lr_d, "D's learning rate")->capture_default_str();
  app->add_option("--ema-g", o->run.task.ema, "Decay of a moving average of G's weights that eval.json and inference use "
                  "(ours; 0: off, G as trained)")->capture_default_str();
  app->add_option("--lr-decay", o->run.task.lr_decay, "Learning rates fall linearly to 0 from this fraction of each stage's "
                  "steps on (ours; 1: constant, the paper)")->capture_default_str();
  add_clip_grad_norm_flag(*app, o->run.task.clip_grad_norm);
  app->add_option("--w-level", o->run.task.w_level, "Weight of L_level: |mean colour of G's output − of its target| on the "
                  "face region, per image and channel (ours; 0: off)")->capture_default_str();
  app->add_option("--makeup-hue", o->run.task.makeup_hue, "Probability that a training sample's makeup is turned to a "
                  "random hue about the grey axis (ours; 0: off, the world's colours)")->capture_default_str();
  app->add_option("--makeup-paint", o->run.task.makeup_paint, "Probability that a training sample's makeup is painted "
                  "over in opaque colours of any hue where it changed the face most (ours; 0: off)")->capture_default_str();
  app->add_option("--diff-gain", o->run.task.diff_gain, "L_diff up to a gain per image and channel on the render's "
                  "albedo (ours; false: the paper): the 3DMM's albedos need not span the skin tones G meets")
      ->capture_default_str();
  app->add_option("--loss-weights", o->weights, "Loss weights over the paper's, JSON with keys w1 (L1), w2 (GAN), w3 "
                  "(LPIPS), w_coeff, w_land, w_diff, w_light, w_reg, w_level, w_makeup, e.g. '{\"w2\": 0.5}'");
  add_trainer_flags(*app, o->run.trainer, false);
  add_profile_flag(*app, o->profile, bareskin_profiles());
  app->get_option("--batch")->description("Batch size (the paper: 4)");
  app->get_option("--resume")->description("Continue the run in the output folder (finished stages are kept)");
  app->add_flag("--evaluate", o->run.evaluate, "Only evaluate the run in the output folder on the test split (eval.json)");
  app->add_option("--eval-samples", o->run.eval_samples, "Test samples the final evaluation reads (0: all)")->capture_default_str();
  app->footer("Examples:\n  bareskin train bareskin --profile cpu --data faces/ --teacher runs/F --model model.safetensors -o runs/bsn\n"
              "  bareskin train bareskin --device cuda --data faces/ --teacher runs/F --model model.safetensors -o runs/bsn\n"
              "docs/training.md, \"BareSkinNet\", describes the losses, the stages and the ablation rows.");
  return [o, app, &globals] {
    const nlohmann::json profile = apply_profile(*app, o->profile, bareskin_profiles());
    set_torch_threads(globals);
    bsn::TrainBareskinOptions run = o->run;
    run.g = json_flag(o->g, "--g-options", "{\"ngf\": 32}");
    run.d = json_flag(o->d, "--d-options", "{\"ndf\": 32}");
    run.weights = json_flag(o->weights, "--loss-weights", "{\"w2\": 0.5}");
    run.student = json_flag(o->student, "--student-options", "{\"width\": 16}");
    run.quiet = globals.quiet();
    run.profile = profile;
    bsn::train_bareskin(run);
  };
}

}  // namespace bareskin::cli
