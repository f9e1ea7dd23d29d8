// bareskin train texture / upscale: pix2pixHD from the UV inputs to the four maps, and SRGAN ×4 per map type
// (texture/pix2pixhd.h; docs/texture.md).
#include <memory>

#include "apps/cli.h"
#include "core/error.h"
#include "core/shards.h"
#include "texture/pix2pixhd.h"
#include "upscale/srgan.h"
#include "training/device.h"

namespace bareskin::cli {
namespace {

struct Common {
  texture::TrainRunOptions run;
  TrainerFlags t;
  std::string model, generator, discriminator, profile;
};

// --profile: "paper" keeps pix2pixHD's and SRGAN's sizes and recipes (the defaults of every flag); "cpu" is what a
// 2-core CPU trains in minutes and still beats the 3DMM-only maps and bicubic on held-out subjects (docs/texture.md,
// "Profiles", gives the chart it was chosen from).
const std::vector<Profile>& texture_profiles() {
  static const std::vector<Profile> profiles = {
      {"paper", "pix2pixHD's GlobalGenerator ngf 64 at 1K with its GAN, feature-matching and VGG losses", {}},
      {"cpu", "the UV net (a U-Net of width 16 correcting the unwrap and the 3DMM's maps, the albedo matched to the "
              "unwrap's level where the photo did not see) at 256², L1 on the UV layout alone (no discriminator), lr "
              "1e-3 with gradients clipped to norm 10, 1500 steps of 4",
       // The clip: a run-pipeline net of the CPU reference diverged at step 650 without it (gradient norm 2-3, then
       // 41); with it that run ends at 20.7 dB and the reference's texture net scores as before or better
       // (bench/BENCHMARKS.md, "The reference's world since 2026-12-06"). The matched fill: the run-pipeline net of
       // the CPU reference lifts Table 1's column (b) diffuse by 0.65 dB with it (bench/BENCHMARKS.md, "What holds
       // column (b)"). The linear output ("tanh": false): a run-pipeline net whose residual's tanh saturated at step
       // 750 never came back; without the tanh the same run recovers from its spike, and the reference's texture net
       // scores as before (bench/BENCHMARKS.md, "The albedo the clamp had broken").
       {{"--arch", "uv"},
        {"--res", "256"},
        {"--generator", R"({"ngf": 16, "fill": "matched", "tanh": false})"},
        {"--lambda-gan", "0"},
        {"--lambda-feat", "0"},
        {"--lambda-perceptual", "0"},
        {"--lambda-l1", "10"},
        {"--lr", "1e-3"},
        {"--clip-grad-norm", "10"},
        {"--batch", "4"},
        {"--steps", "1500"}},
       // The generator's keys are the UV net's ("fill"): a --generator given, e.g. beside --arch global, replaces
       // them whole.
       {"--generator"}},
  };
  return profiles;
}

const std::vector<Profile>& upscale_profiles() {
  static const std::vector<Profile> profiles = {
      {"paper", "MSRResNet 64 features, 16 blocks; the GAN phase from a pixel-loss run (--init)", {}},
      {"cpu", "MSRResNet 16 features, 4 blocks, the pixel-loss phase alone (MSE over the bicubic base), lr 2e-3 "
              "falling linearly to 0, 2400 steps of 2 crops of 128²",
       // 2400 steps, not 600, with the rate falling linearly from the first step: held out, 1K -> 4K over bicubic
       // (diffuse / roughness / specular), 600 constant steps +0.5 / -0.0 / +0.4 dB, 2400 constant +2.7 / +1.4 / +0.6,
       // 2400 decaying +4.2 / +3.4 / +3.1 (bench/BENCHMARKS.md, "Texture inference").
       {{"--phase", "l1"},
        {"--generator", R"({"num_feat": 16, "num_block": 4})"},
        {"--patch", "128"},
        {"--lr", "2e-3"},
        {"--lr-decay", "0"},
        {"--batch", "2"},
        {"--steps", "2400"}}},
  };
  return profiles;
}

// Flags both trainings share.
void add_common(CLI::App* app, Common& c) {
  app->add_option("--data", c.run.data, "Texture shards: the train split (texgen make-dataset)")->required();
  app->add_option("--val", c.run.val, "Validation split (PSNR per map in eval.csv, sample grids)");
  app->add_option("-o,--output", c.run.output, "Run folder")->required();
  app->add_option("--model", c.model,
                  "The morphable model the dataset was made with: its CRC-32 is recorded, and 'bareskin run' refuses "
                  "another model with this run");
  c.t = {c.run.steps, c.run.batch, c.run.log_every, c.run.checkpoint_every, c.run.eval_every, c.run.sample_every,
         c.run.seed, c.run.resume, c.run.device};
  add_trainer_flags(*app, c.t);
  app->add_option("--decode-threads", c.run.decode_threads, "PNG decode threads")->capture_default_str();
  app->add_option("--generator", c.generator, "Generator options over the zoo defaults (JSON)");
  app->add_option("--discriminator", c.discriminator, "Discriminator options over the zoo defaults (JSON)");
}

void finish_common(Common& c, const Globals& globals) {
  c.run.steps = c.t.steps;
  c.run.batch = c.t.batch;
  c.run.log_every = c.t.log_every;
  c.run.checkpoint_every = c.t.checkpoint_every;
  c.run.eval_every = c.t.eval_every;
  c.run.sample_every = c.t.sample_every;
  c.run.seed = c.t.seed;
  c.run.resume = c.t.resume;
  c.run.device = parse_device(c.t.device).str();
  c.run.progress = !globals.quiet();
  c.run.extra["threads"] = globals.threads;
  c.run.extra["model_crc32"] = c.model.empty() ? nlohmann::json() : nlohmann::json(shards::file_crc32(c.model));
}

}  // namespace

// Registers `train texture` and `train upscale`; the returned function runs the one chosen (false: neither was).
std::function<bool()> setup_train_texture(CLI::App& train, const Globals& globals) {
  auto tex = std::make_shared<Common>();
  auto tex_model = std::make_shared<texture::TextureNetOptions>();
  CLI::App* t = train.add_subcommand("texture", "pix2pixHD: UV inputs -> diffuse, normal, roughness, specular (1K)");
  add_common(t, *tex);
  t->add_option("--masks", tex->run.masks, "Occlusion masks (a masks/ shard set); default: synthetic occluders");
  t->add_option("--res", tex_model->res, "Map size the net works at (inputs and targets are resized)")
      ->capture_default_str();
  t->add_option("--arch", tex_model->generator, "global (pix2pixHD's GlobalGenerator), local (its LocalEnhancer) or uv (a U-Net "
                                           "correcting the unwrap and the 3DMM's maps; docs/texture.md)")
      ->capture_default_str();
  t->add_option("--lambda-gan", tex_model->lambda_gan, "Adversarial weight")->capture_default_str();
  t->add_option("--lambda-feat", tex_model->lambda_feat, "Feature matching weight")->capture_default_str();
  t->add_option("--lambda-perceptual", tex_model->lambda_perceptual, "VGG loss weight (vgg16-random trunk)")
      ->capture_default_str();
  t->add_option("--lambda-l1", tex_model->lambda_l1, "Optional L1 to the targets (not in pix2pixHD)")
      ->capture_default_str();
  t->add_option("--lr", tex_model->lr, "Adam learning rate")->capture_default_str();
  t->add_option("--lr-decay", tex_model->lr_decay, "The rate falls linearly to 0 from this fraction of the steps on "
                "(0.5: pix2pixHD's niter = niter_decay; 1: constant)")->capture_default_str();
  add_clip_grad_norm_flag(*t, tex_model->clip_grad_norm);
  add_profile_flag(*t, tex->profile, texture_profiles());
  t->footer("Example: bareskin train texture --profile cpu --data textures/train --val textures/val --masks "
            "textures/masks --model model.safetensors -o runs/tex\n"
            "         bareskin train texture --data textures/train --val textures/val --masks textures/masks "
            "--model model.safetensors -o runs/tex --res 1024 --steps 200000");

  auto up = std::make_shared<Common>();
  auto up_model = std::make_shared<texture::UpscaleOptions>();
  CLI::App* u = train.add_subcommand("upscale", "SRGAN x4 (MSRResNet) for one map type: 1K -> 4K");
  add_common(u, *up);
  u->add_option("--map", up_model->map, "diffuse, normal, roughness or specular")->capture_default_str();
  u->add_option("--phase", up_model->phase, "l1 (pre-training with the pixel loss) or gan (from --init)")
      ->capture_default_str();
  u->add_option("--init", up->run.init, "GAN phase: the L1 run whose generator it starts from");
  u->add_option("--patch", up_model->patch, "High-resolution crop (128 or 256)")->capture_default_str();
  u->add_option("--pixel-loss", up_model->pixel_loss, "Pre-training loss: mse (SRGAN's SRResNet) or l1 (BasicSR)")
      ->capture_default_str();
  u->add_option("--base", up_model->base, "The upsampling the net adds its output to: bicubic (ours) or bilinear "
                                          "(BasicSR)")->capture_default_str();
  u->add_option("--pool", up->run.pool, "Decoded maps kept for cropping")->capture_default_str();
  u->add_option("--crops-per-map", up->run.crops_per_map, "Crops drawn per decoded map before it is replaced")
      ->capture_default_str();
  u->add_option("--lambda-gan", up_model->lambda_gan, "Adversarial weight")->capture_default_str();
  u->add_option("--lambda-perceptual", up_model->lambda_perceptual, "VGG loss weight")->capture_default_str();
  u->add_option("--lr", up_model->lr, "Adam learning rate")->capture_default_str();
  u->add_option("--lr-decay", up_model->lr_decay, "The rate falls linearly to 0 from this fraction of the steps on (1: "
                "constant, as SRGAN's first 10^5 steps)")->capture_default_str();
  add_clip_grad_norm_flag(*u, up_model->clip_grad_norm);
  add_profile_flag(*u, up->profile, upscale_profiles());
  u->footer("Example: bareskin train upscale --profile cpu --map diffuse --data textures/train --val textures/val "
            "-o runs/up_diffuse\n"
            "         bareskin train upscale --map diffuse --phase l1 --data textures/train -o runs/up_l1\n"
            "         bareskin train upscale --map diffuse --phase gan --init runs/up_l1 --data textures/train "
            "-o runs/up");

  return [&globals, t, u, tex, tex_model, up, up_model] {
    if (t->parsed()) {
      tex->run.extra["profile"] = apply_profile(*t, tex->profile, texture_profiles());
      finish_common(*tex, globals);
      tex_model->generator_options = json_flag(tex->generator, "--generator", "{\"ngf\": 16}");
      tex_model->discriminator_options = json_flag(tex->discriminator, "--discriminator", "{\"ngf\": 16}");
      *tex_model = nlohmann::json(*tex_model).get<texture::TextureNetOptions>();  // range checks
      texture::train_texture(tex->run, *tex_model);
      return true;
    }
    if (u->parsed()) {
      up->run.extra["profile"] = apply_profile(*u, up->profile, upscale_profiles());
      finish_common(*up, globals);
      up_model->generator_options = json_flag(up->generator, "--generator", "{\"ngf\": 16}");
      up_model->discriminator_options = json_flag(up->discriminator, "--discriminator", "{\"ngf\": 16}");
      *up_model = nlohmann::json(*up_model).get<texture::UpscaleOptions>();  // range checks
      texture::train_upscale(up->run, *up_model);
      return true;
    }
    return false;
  };
}

}  // namespace bareskin::cli
