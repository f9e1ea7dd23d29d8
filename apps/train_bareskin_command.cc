// bareskin train bareskin: BareSkinNet's two stages (bareskinnet/bareskinnet.h) on `texgen faces` samples, with the
// teacher F of `bareskin train recon`. docs/training.md, "BareSkinNet"; docs/cli.md.
#include <filesystem>
#include <iostream>
#include <set>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/shards.h"
#include "detect/face_api.h"
#include "bareskinnet/bareskinnet.h"
#include "training/device.h"
#include "training/ranks.h"
#include "recon/face_model.h"

namespace bareskin::cli {
namespace fs = std::filesystem;

namespace {
// --profile: "paper" keeps the paper's sizes and recipe (the defaults of every flag); "cpu" is what a 2-core CPU
// trains in minutes to hours and still learns its task (docs/training.md, "Profiles", gives the chart it was chosen
// from).
const std::vector<Profile>& bareskin_profiles() {
  static const std::vector<Profile> profiles = {
      {"paper", "G ngf 64 at 256², 10k + 30k steps of 4, lr 2e-5 (a GPU's days)", {}},
      {"cpu", "G ngf 16 with the affine head at 128², D ndf 16, E width 16, 1500 + 300 steps of 8, lr 2e-4, the bare "
              "target, LPIPS on face-api's net, L_diff and L_light at 10",
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
        // Stage 2 pulls G towards F's unlit render, whose albedo a small 3DMM draws coarsely: at the paper's 100 it
        // undid stage 1 on held-out faces (demo world: 24.82 → 21.54 dB in 60 steps), at 10 it keeps it (24.69).
        {"--loss-weights", R"({"w_diff": 10, "w_light": 10})"}}},
  };
  return profiles;
}
}  // namespace

std::function<void()> setup_train_bareskin(CLI::App& train, const Globals& globals) {
  struct Options {
    std::string data, teacher, model, output = "runs/bsn", ablation, g, d, student, weights, profile;
    bsn::Options task;
    int64_t steps1 = 10000, steps2 = 30000;
    TrainerFlags t;
    bool evaluate = false;
    int64_t eval_samples = 0;
  };
  auto o = std::make_shared<Options>();
  o->t.batch = 4;
  CLI::App* app = train.add_subcommand("bareskin", "Train BareSkinNet: stage 1 (G alone), stage 2 (G + E with the frozen teacher F)");
  app->add_option("--data", o->data, "Face samples of 'texgen faces' (train/ and val/ inside)")->required();
  app->add_option("--teacher", o->teacher, "The teacher F: a 'bareskin train recon' run folder (needed by stage 2)");
  app->add_option("--model", o->model, "The morphable model F was trained with (model.safetensors; needed by stage 2)");
  app->add_option("-o,--output", o->output, "Run folder (stage1/ and stage2/ inside)")->capture_default_str();
  app->add_option("--steps1", o->steps1, "Stage-1 iterations (the paper: 10000)")->capture_default_str()
      ->check(CLI::Range(1, 1000000000));
  app->add_option("--steps2", o->steps2, "Stage-2 iterations (the paper: 30000; 0: stage 1 only)")
      ->capture_default_str()->check(CLI::Range(0, 1000000000));
  app->add_option("--size", o->task.size, "Training resolution (a power of two; the samples are area-resized)")->capture_default_str();
  app->add_option("--target", o->task.target, "G's supervision: before (the paper) or bare (the albedo truth)")
      ->check(CLI::IsMember({"before", "bare"}))->capture_default_str();
  app->add_option("--ablation", o->ablation, "A row of the paper's Fig. 7: b (L1+GAN), c (+LPIPS), d (+frozen F), "
                  "e (+fine-tuned F), f (+E without L_light), g (full)")->check(CLI::IsMember({"b", "c", "d", "e", "f", "g"}));
  app->add_option("--head", o->task.head, "How G's image comes from its U-Net: residual (input + Δ), affine (input · "
                  "gain + offset per pixel) or image (the paper); residual and affine start as the identity")
      ->check(CLI::IsMember({"residual", "affine", "image"}))->capture_default_str();
  app->add_option("--lpips", o->task.lpips_trunk, "LPIPS trunk: vgg16-random or facenet (cheap on the CPU)")
      ->check(CLI::IsMember({"vgg16-random", "facenet"}))->capture_default_str();
  app->add_option("--g-options", o->g, "G (unet256) options over the defaults, JSON, e.g. '{\"ngf\": 16}'");
  app->add_option("--d-options", o->d, "D (patchgan) options, JSON");
  app->add_option("--student-options", o->student, "E options (recon net), JSON, e.g. '{\"width\": 16}'");
  app->add_option("--lr-g", o->task.lr_g, "G's learning rate (the paper: 2e-5)")->capture_default_str();
  app->add_option("--lr-e", o->task.lr_e, "E's learning rate (the paper: 1e-4)")->capture_default_str();
  app->add_option("--lr-d", o->task.lr_d, "D's learning rate")->capture_default_str();
  app->add_option("--ema-g", o->task.ema, "Decay of a moving average of G's weights that eval.json and inference use "
                  "(ours; 0: off, G as trained)")->capture_default_str();
  app->add_option("--lr-decay", o->task.lr_decay, "Learning rates fall linearly to 0 from this fraction of each stage's "
                  "steps on (ours; 1: constant, the paper)")->capture_default_str();
  app->add_option("--w-level", o->task.w_level, "Weight of L_level: |mean colour of G's output − of its target| on the "
                  "face region, per image and channel (ours; 0: off)")->capture_default_str();
  app->add_option("--loss-weights", o->weights, "Loss weights over the paper's, JSON with keys w1 (L1), w2 (GAN), w3 "
                  "(LPIPS), w_coeff, w_land, w_diff, w_light, w_reg, w_level, e.g. '{\"w2\": 0.5}'");
  add_trainer_flags(*app, o->t, false);
  add_profile_flag(*app, o->profile, bareskin_profiles());
  app->get_option("--batch")->description("Batch size (the paper: 4)");
  app->get_option("--resume")->description("Continue the run in the output folder (finished stages are kept)");
  app->add_flag("--evaluate", o->evaluate, "Only evaluate the run in the output folder on the test split (eval.json)");
  app->add_option("--eval-samples", o->eval_samples, "Test samples the final evaluation reads (0: all)")->capture_default_str();
  app->footer("Examples:\n  bareskin train bareskin --profile cpu --data faces/ --teacher runs/F --model model.safetensors -o runs/bsn\n"
              "  bareskin train bareskin --device cuda --data faces/ --teacher runs/F --model model.safetensors -o runs/bsn\n"
              "docs/training.md, \"BareSkinNet\", describes the losses, the stages and the ablation rows.");
  return [o, app, &globals] {
    const nlohmann::json profile = apply_profile(*app, o->profile, bareskin_profiles());
    set_torch_threads(globals);
    const torch::Device device = parse_device(o->t.device);
    const shards::Splits data_splits = shards::find_splits(o->data, "give the folder 'bareskin texgen faces' wrote");
    bsn::Options task = o->task;
    task.g = json_flag(o->g, "--g-options", "{\"ngf\": 32}");
    task.d = json_flag(o->d, "--d-options", "{\"ndf\": 32}");
    if (!o->ablation.empty()) bsn::ablation_preset(o->ablation, task);
    nlohmann::json check = task;
    const nlohmann::json weights = json_flag(o->weights, "--loss-weights", "{\"w2\": 0.5}");  // named: items() of a temporary dangles
    for (auto& [key, value] : weights.items()) {
      static const std::set<std::string> kWeights{"w1", "w2", "w3", "w_coeff", "w_land", "w_diff", "w_light", "w_reg", "w_level"};
      if (!kWeights.count(key) || !value.is_number())
        throw InvalidInput("--loss-weights", "'" + key + "' is not a loss weight with a number",
                           "use the keys w1, w2, w3, w_coeff, w_land, w_diff, w_light, w_reg, w_level");
      check[key] = value;
    }
    bsn::from_json(check, task);  // validates size, target, ...
    if (task.lpips_trunk == "facenet") task.face_api = detect::default_face_api_folder();
    if (!o->ablation.empty() && !bsn::ablation_has_stage2(o->ablation)) o->steps2 = 0;
    const nlohmann::json student_options = json_flag(o->student, "--student-options", "{\"width\": 16}");
    if (o->steps2 > 0 && !o->evaluate) {
      if (o->teacher.empty())
        throw InvalidInput("--teacher", "is needed by stage 2", "give a 'bareskin train recon' run, or --steps2 0");
      bsn::check_teacher(o->teacher);
      if (o->model.empty())
        throw InvalidInput("--model", "is needed by stage 2", "give the model.safetensors the teacher was trained with");
      if (!fs::exists(o->model)) throw IoError(o->model, "does not exist", "give the morphable model file");
    }
    bsn::RunOptions ro;
    ro.task = task;
    ro.train_data = data_splits.train;
    ro.val_data = data_splits.val;
    ro.run_dir = o->output;
    ro.steps1 = o->steps1;
    ro.steps2 = o->steps2;
    ro.batch = o->t.batch;
    ro.seed = o->t.seed;
    ro.profile = profile;
    if (!o->teacher.empty()) ro.teacher = fs::absolute(o->teacher).string();
    if (!o->model.empty()) ro.model = fs::absolute(o->model).string();
    ro.trainer.resume = o->t.resume;
    ro.trainer.device = device;
    ro.trainer.log_every = o->t.log_every;
    ro.trainer.checkpoint_every = o->t.checkpoint_every;
    ro.trainer.eval_every = ro.val_data.empty() ? 0 : o->t.eval_every;
    ro.trainer.sample_every = o->t.sample_every;
    ro.trainer.progress = !globals.quiet();
    // The held-out evaluation (test/: unseen subjects and makeup styles) into <run>/eval.json.
    bsn::RunEvalOptions eval;
    eval.lpips_trunk = task.lpips_trunk;
    eval.max_samples = o->eval_samples;
    eval.device = device;
    eval.required = o->evaluate;
    eval.quiet = globals.quiet();
    if (o->evaluate) return bsn::evaluate_run(o->output, o->data, eval);
    // Check the teacher before stage 1 spends its time: a wrong checkpoint fails at once.
    std::shared_ptr<recon::FaceModel> model;
    if (o->steps2 > 0) {
      model = std::make_shared<recon::FaceModel>(recon::FaceModel::load(o->model).to(device));
      bsn::load_teacher(o->teacher, *model);
    }
    auto parts = [&] {
      bsn::Stage2Parts p;
      p.teacher = bsn::load_teacher(o->teacher, *model);
      p.student = bsn::make_student(*model, student_options);
      p.teacher.module->to(device);
      p.student.module->to(device);
      p.renderer = bsn::model_renderer(model);
      p.layout = model->layout(false);
      return p;
    };
    auto result = bsn::train_two_stages(ro, parts);
    if (!globals.quiet()) {
      for (const auto* r : {&result.stage1, &result.stage2})
        for (auto& [k, v] : r->last_eval) std::cerr << (r == &result.stage1 ? "stage 1 " : "stage 2 ") << k << " " << v << "\n";
      std::cerr << "wrote " << o->output << "/stage1" << (o->steps2 > 0 ? " and stage2" : "") << "\n";
    }
    if (dist::Environment::from_env().rank != 0) return;  // one of several ranks: rank 0 writes the run folder
    if (result.stage1.steps + result.stage2.steps > 0 || !fs::exists(o->output + "/eval.json"))
      bsn::evaluate_run(o->output, o->data, eval);
  };
}

}  // namespace bareskin::cli
