// `bareskin train recon`'s run (train_recon.h): the samples, the identity net, the task and the Trainer.
#include "recon/train_recon.h"

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/shards.h"
#include "detect/face_api.h"
#include "recon/recon.h"
#include "training/device.h"
#include "training/ranks.h"
#include "training/trainer.h"

namespace bareskin::recon {

void TrainReconOptions::check() const {
  if (data.empty()) throw InvalidInput("--data", "is missing", "give the folder 'bareskin texgen faces' wrote");
  if (model.empty()) throw InvalidInput("--model", "is missing", "give the morphable model file (mm-build)");
  if (output.empty()) throw InvalidInput("-o", "names no run folder", "give the run's output folder");
  if (gamma != "on" && gamma != "off" && gamma != "auto")
    throw InvalidInput("--gamma", "'" + gamma + "' is not on, off or auto", "e.g. --gamma auto");
  parse_supervision(supervision);
  if (!loss.is_object()) throw InvalidInput("--loss", "is not a JSON object", "e.g. '{\"identity\": 0}'");
  if (image_size != 0 && (image_size < 16 || image_size > 4096))
    throw InvalidInput("--image-size", std::to_string(image_size) + " is outside [16, 4096]", "0 keeps the samples' size");
  if (decay_every < -1) throw InvalidInput("--decay-every", "must be >= -1", "0: half the steps; -1: never");
  if (!(clip_grad_norm >= 0 && std::isfinite(clip_grad_norm)))
    throw InvalidInput("--clip-grad-norm", "must be finite and >= 0", "0 is off, e.g. --clip-grad-norm 10");
  if (!(colour_jitter >= 0 && colour_jitter <= 1))
    throw InvalidInput("--colour-jitter", "must lie in [0, 1]", "0 is off, e.g. --colour-jitter 0.2");
  if (eval_batches < 1) throw InvalidInput("--eval-batches", "must be at least 1", "e.g. --eval-batches 8");
  ReconNetOptions net;
  net.arch = arch;
  net.width = width;
  net.pool_grid = pool_grid;
  net.check();
  ReconTaskOptions task;
  task.input = input;
  task.lr = lr;
  task.check();
  trainer.check();
}

TrainReconResult train_recon(const TrainReconOptions& o) {
  namespace fs = std::filesystem;
  o.check();
  const torch::Device device = parse_device(o.trainer.device);
  if (!fs::exists(o.model)) throw IoError(o.model, "does not exist", "give the morphable model file (mm-build)");
  ReconTaskOptions to;
  to.net.arch = o.arch;
  to.net.width = o.width;
  to.net.pool_grid = o.pool_grid;
  to.net.gamma = o.gamma == "auto" ? o.arch == "resnet50" : o.gamma == "on";
  to.net.check();
  to.loss.supervision = parse_supervision(o.supervision);
  from_json(o.loss, to.loss);
  to.input = o.input;
  to.lr = o.lr;
  to.schedule.step_every = o.decay_every > 0 ? o.decay_every : o.decay_every == 0 ? std::max<int64_t>(1, o.trainer.steps / 2) : 0;
  if (to.schedule.step_every == 0) to.schedule.kind = "constant";
  const FaceModel model = FaceModel::load(o.model);
  const auto [train_dir, val_dir] = shards::find_splits(o.data, "give the folder 'bareskin texgen faces' wrote");
  data::LoaderOptions lo;
  lo.dataset = train_dir;
  lo.required = {o.input + ".png", "json"};
  lo.batch_size = o.trainer.batch;
  lo.seed = o.trainer.seed;
  if (o.colour_jitter > 0)
    lo.transform = [member = o.input, s = o.colour_jitter](data::Example& e, uint64_t seed) {
      jitter_colour(e, member, s, seed);
    };
  data::ShardLoader loader(dist::this_rank(lo));
  {
    // The image size from the first sample; the nets take any size, the face model renders at it.
    data::LoaderOptions peek = lo;
    peek.batch_size = 1;
    peek.shuffle_buffer = 0;
    peek.decode_threads = 1;
    const data::Batch b = data::ShardLoader(peek).next();
    to.image_size = b.at(o.input).size(3);
    if (b.at(o.input).size(2) != to.image_size) throw InvalidInput(train_dir, "the samples are not square", "");
    if (o.image_size > 0) to.image_size = o.image_size;
  }
  std::unique_ptr<data::ShardLoader> val;
  if (!val_dir.empty()) {
    data::LoaderOptions vo = lo;
    vo.dataset = val_dir;
    vo.shuffle_buffer = 0;
    vo.transform = nullptr;  // validation scores the photos as they are
    val = std::make_unique<data::ShardLoader>(vo);
  }
  std::shared_ptr<detect::FaceRecognitionNet> identity;
  if (to.loss.identity > 0 && to.loss.supervision != Supervision::Truth) {
    identity = std::make_shared<detect::FaceRecognitionNet>(detect::default_face_api_folder());
    (*identity)->to(device);
    (*identity)->eval();
    for (auto& p : (*identity)->parameters()) p.requires_grad_(false);
  }
  train::seed_everything(o.trainer.seed);
  ReconTask task(to, model, identity, device);
  train::TrainerOptions topt;
  topt.run_dir = o.output;
  topt.steps = o.trainer.steps;
  topt.log_every = o.trainer.log_every;
  topt.checkpoint_every = o.trainer.checkpoint_every;
  topt.eval_every = val ? o.trainer.eval_every : 0;
  topt.eval_batches = o.eval_batches;
  topt.sample_every = o.trainer.sample_every;
  topt.resume = o.trainer.resume;
  topt.device = device;
  topt.progress = o.progress;
  topt.clip_grad_norm = o.clip_grad_norm;
  topt.config = {{"net", to.net}, {"loss", to.loss}, {"input", to.input}, {"image_size", to.image_size},
                 {"model", fs::absolute(o.model).string()},
                 {"layout", {{"id", model.layout().id}, {"exp", model.layout().exp}, {"app", model.layout().app}}},
                 {"data", o.data}, {"batch", o.trainer.batch}, {"lr", o.lr}, {"clip_grad_norm", o.clip_grad_norm},
                 {"colour_jitter", o.colour_jitter},
                 {"decay_every", o.decay_every},
                 {"seed", o.trainer.seed}, {"steps", o.trainer.steps}, {"log_every", o.trainer.log_every},
                 {"checkpoint_every", o.trainer.checkpoint_every}, {"eval_every", topt.eval_every},
                 {"eval_batches", o.eval_batches}, {"sample_every", o.trainer.sample_every}, {"device", o.trainer.device}};
  topt.config["profile"] = o.profile;
  topt.resumable_keys.push_back("profile");  // runs made before profiles existed have none
  // A run's stored net options and loss weights read back in today's keys, so runs from before a key existed
  // (pool_grid, shape, clip_grad_norm and colour_jitter: off) resume.
  topt.upgrade_config = [](nlohmann::json& stored) {
    if (!stored.contains("clip_grad_norm")) stored["clip_grad_norm"] = 0.0;
    if (!stored.contains("colour_jitter")) stored["colour_jitter"] = 0.0;
    if (stored.contains("net")) stored["net"] = nlohmann::json(stored["net"].get<ReconNetOptions>());
    if (stored.contains("loss")) stored["loss"] = nlohmann::json(stored["loss"].get<LossOptions>());
  };
  train::Trainer trainer(topt, task, loader, val.get());
  const train::TrainResult result = trainer.run();
  return {task.module_name(), result.steps, result.last_eval};
}

}  // namespace bareskin::recon
