// `bareskin train bareskin`'s run (train_bareskin.h): the options checked, the teacher and student of stage 2, the
// two stages and the held-out evaluation.
#include "bareskinnet/train_bareskin.h"

#include <filesystem>
#include <iostream>
#include <set>

#include "bareskinnet/bareskinnet.h"
#include "core/error.h"
#include "core/shards.h"
#include "detect/face_api.h"
#include "recon/face_model.h"
#include "training/device.h"
#include "training/ranks.h"

namespace bareskin::bsn {

void TrainBareskinOptions::check() const {
  if (data.empty()) throw InvalidInput("--data", "is missing", "give the folder 'bareskin texgen faces' wrote");
  if (output.empty()) throw InvalidInput("-o", "names no run folder", "give the run's output folder");
  if (!ablation.empty()) {
    Options row;
    ablation_preset(ablation, row);  // InvalidInput for a row the paper does not have
  }
  using Flag = std::pair<const char*, const nlohmann::json*>;
  for (const Flag& f : {Flag{"--g-options", &g}, Flag{"--d-options", &d}, Flag{"--student-options", &student},
                        Flag{"--loss-weights", &weights}})
    if (!f.second->is_object()) throw InvalidInput(f.first, "is not a JSON object", "give e.g. '{}'");
  for (auto& [key, value] : weights.items()) {
    static const std::set<std::string> kWeights{"w1",     "w2",    "w3",      "w_coeff", "w_land",
                                                "w_diff", "w_light", "w_reg", "w_level", "w_makeup"};
    if (!kWeights.count(key) || !value.is_number())
      throw InvalidInput("--loss-weights", "'" + key + "' is not a loss weight with a number",
                         "use the keys w1, w2, w3, w_coeff, w_land, w_diff, w_light, w_reg, w_level, w_makeup");
  }
  if (steps1 < 1) throw InvalidInput("--steps1", "must be at least 1", "e.g. --steps1 1500");
  if (steps2 < 0) throw InvalidInput("--steps2", "must not be negative", "0 runs stage 1 only");
  if (eval_samples < 0) throw InvalidInput("--eval-samples", "must not be negative", "0 takes every sample");
  trainer.check();
}

void train_bareskin(TrainBareskinOptions o) {
  namespace fs = std::filesystem;
  o.check();
  const torch::Device device = parse_device(o.trainer.device);
  const shards::Splits data_splits = shards::find_splits(o.data, "give the folder 'bareskin texgen faces' wrote");
  Options task = o.task;
  task.g = o.g;
  task.d = o.d;
  nlohmann::json check = task;
  for (auto& [key, value] : o.weights.items()) check[key] = value;
  from_json(check, task);  // validates size, target, ...
  // The row of the ablation last: what it leaves out stays out whatever weights a profile or --loss-weights give.
  if (!o.ablation.empty()) ablation_preset(o.ablation, task);
  if (task.lpips_trunk == "facenet") task.face_api = detect::default_face_api_folder();
  if (!o.ablation.empty() && !ablation_has_stage2(o.ablation)) o.steps2 = 0;
  if (o.steps2 > 0 && !o.evaluate) {
    if (o.teacher.empty())
      throw InvalidInput("--teacher", "is needed by stage 2", "give a 'bareskin train recon' run, or --steps2 0");
    if (o.model.empty())
      throw InvalidInput("--model", "is needed by stage 2", "give the model.safetensors the teacher was trained with");
  }
  // A teacher or model given only for the evaluation's albedo metrics is checked before stage 1 spends its time too.
  if (!o.teacher.empty()) check_teacher(o.teacher);
  if (!o.model.empty() && !fs::exists(o.model)) throw IoError(o.model, "does not exist", "give the morphable model file");
  RunOptions ro;
  ro.task = task;
  ro.train_data = data_splits.train;
  ro.val_data = data_splits.val;
  ro.run_dir = o.output;
  ro.steps1 = o.steps1;
  ro.steps2 = o.steps2;
  ro.batch = o.trainer.batch;
  ro.seed = o.trainer.seed;
  ro.profile = o.profile;
  if (!o.teacher.empty()) ro.teacher = fs::absolute(o.teacher).string();
  if (!o.model.empty()) ro.model = fs::absolute(o.model).string();
  ro.trainer.resume = o.trainer.resume;
  ro.trainer.device = device;
  ro.trainer.log_every = o.trainer.log_every;
  ro.trainer.checkpoint_every = o.trainer.checkpoint_every;
  ro.trainer.eval_every = ro.val_data.empty() ? 0 : o.trainer.eval_every;
  ro.trainer.sample_every = o.trainer.sample_every;
  ro.trainer.progress = !o.quiet;
  // The held-out evaluation (test/: unseen subjects and makeup styles) into <run>/eval.json.
  RunEvalOptions eval;
  eval.lpips_trunk = task.lpips_trunk;
  eval.max_samples = o.eval_samples;
  eval.device = device;
  eval.required = o.evaluate;
  eval.quiet = o.quiet;
  if (o.evaluate) return evaluate_run(o.output, o.data, eval);
  // Check the teacher before stage 1 spends its time: a wrong checkpoint fails at once.
  std::shared_ptr<recon::FaceModel> model;
  if (o.steps2 > 0) {
    model = std::make_shared<recon::FaceModel>(recon::FaceModel::load(o.model).to(device));
    load_teacher(o.teacher, *model);
  }
  auto parts = [&] {
    Stage2Parts p;
    p.teacher = load_teacher(o.teacher, *model);
    p.student = make_student(*model, o.student);
    p.teacher.module->to(device);
    p.student.module->to(device);
    p.renderer = model_renderer(model);
    p.layout = model->layout(false);
    return p;
  };
  auto result = train_two_stages(ro, parts);
  if (!o.quiet) {
    for (const auto* r : {&result.stage1, &result.stage2})
      for (auto& [k, v] : r->last_eval) std::cerr << (r == &result.stage1 ? "stage 1 " : "stage 2 ") << k << " " << v << "\n";
    std::cerr << "wrote " << o.output << "/stage1" << (o.steps2 > 0 ? " and stage2" : "") << "\n";
  }
  if (dist::Environment::from_env().rank != 0) return;  // one of several ranks: rank 0 writes the run folder
  if (result.stage1.steps + result.stage2.steps > 0 || !fs::exists(o.output + "/eval.json"))
    evaluate_run(o.output, o.data, eval);
}

}  // namespace bareskin::bsn
