#include "avatar/run_dataset.h"

#include <cmath>
#include <map>
#include <memory>
#include <set>

#include "core/error.h"
#include "core/files.h"
#include "core/log.h"
#include "core/png.h"
#include "core/shards.h"
#include "training/data.h"

namespace bareskin::texture {
namespace {

const char* const kMaps[] = {"diffuse", "normal", "roughness", "specular"};

// The true maps of each subject of a make-dataset split: the first sample's map members, as stored.
std::map<std::string, std::map<std::string, std::string>> true_maps(const std::string& split) {
  std::map<std::string, std::map<std::string, std::string>> out;
  const shards::Manifest manifest = shards::open_dataset(split);
  for (const auto& info : manifest.shards) {
    shards::ShardReader reader(shards::shard_path(split, info));
    shards::Sample sample;
    while (reader.next(sample)) {
      auto json_it = sample.members.find("json");
      if (json_it == sample.members.end()) continue;
      const std::string subject = subject_key(nlohmann::json::parse(json_it->second).value("subject", ""));
      if (subject.empty() || out.count(subject)) continue;
      std::map<std::string, std::string> maps;
      for (const char* m : kMaps) {
        auto it = sample.members.find(std::string(m) + ".png");
        if (it == sample.members.end())
          throw InvalidInput(split + ": sample " + sample.key, std::string("has no ") + m + ".png",
                             "give a texgen make-dataset split (it stores the four true maps)");
        maps[std::string(m) + ".png"] = std::move(it->second);
      }
      out[subject] = std::move(maps);
    }
  }
  return out;
}

}  // namespace

void RunDatasetOptions::check() const {
  if (faces.empty()) throw InvalidInput("--faces", "is empty", "give a texgen faces split");
  if (textures.empty()) throw InvalidInput("--textures", "is empty", "give the texgen make-dataset split of the subjects");
  if (output.empty()) throw InvalidInput("-o", "is empty", "give the dataset folder to write");
  if (model.empty()) throw InvalidInput("--model", "is empty", "give the morphable model (model.safetensors)");
  if (image != "makeup" && image != "before")
    throw InvalidInput("--image", "is '" + image + "'", "use makeup or before");
  if (input_res < 16 || input_res > 4096) throw InvalidInput("--input-res", "is out of range", "use 16–4096");
  if (max_samples < 0) throw InvalidInput("--max-samples", "is negative", "use 0 (all) or a count");
  if (shard_size < 1) throw InvalidInput("--shard-size", "is below 1", "use a positive count");
}

RunDatasetReport write_run_dataset(const RunDatasetOptions& o, const ProgressCallback& progress) {
  o.check();
  const MorphableModel model = read_model(o.model);
  const Demakeup G = o.bareskin.empty() ? Demakeup() : load_demakeup(o.bareskin, o.device);
  std::unique_ptr<const recon::TrainedRecon> F;
  if (!o.teacher.empty())
    F = std::make_unique<const recon::TrainedRecon>(
        recon::load_recon(o.teacher, recon::FaceModel::load(o.model), torch::Device(o.device)));
  if (o.face_masks) require_face_masks(o.faces, "--no-face-masks");
  const auto truth = true_maps(o.textures);
  data::LoaderOptions lo;
  lo.dataset = o.faces;
  lo.required = {o.image + ".png", "json"};
  if (o.face_masks) lo.required.push_back("face.png");
  lo.batch_size = 1;
  lo.shuffle_buffer = 0;
  data::ShardLoader faces(lo);
  const int64_t n = faces.epoch_size();

  AvatarOptions ao;
  ao.input_res = o.input_res;
  RunDatasetReport result;
  std::set<std::string> subjects;
  double psnr_sum = 0;
  AtomicDirectory out(o.output);
  {
    shards::ShardWriter writer(out.path(), "texture", o.shard_size);
    for (int64_t i = 0; i < n && (o.max_samples == 0 || result.samples < o.max_samples); ++i) {
      const data::Batch b = faces.next();
      report(progress, i + 1, n, "faces");
      const nlohmann::json& meta = b.meta[0];
      const std::string subject = subject_key(meta.value("subject", ""));
      auto t = truth.find(subject);
      if (t == truth.end()) {
        ++result.without_truth;
        continue;
      }
      const Image face = tensor_image(b.at(o.image), ColorSpace::sRGB);
      const Image mask = o.face_masks ? tensor_image(b.at("face"), ColorSpace::Data) : Image();
      const detect::Landmarks68 landmarks = sample_landmarks(b);
      const Image bare = G ? G(face) : face;
      const Coefficients c = fit_coefficients(bare, landmarks, model, F.get(), ao);
      const TextureInputs in = texture_inputs(bare, c, model, o.input_res, mask);

      Image diffuse = decode_png(t->second.at("diffuse.png"), o.textures + ": " + subject + " diffuse.png");
      diffuse.color_space = ColorSpace::sRGB;
      const double psnr = texgen::masked_psnr_srgb(to_linear(in.unwrap), to_linear(resize_square(diffuse, o.input_res)),
                                                   in.confidence);
      if (std::isfinite(psnr)) psnr_sum += psnr;
      shards::Sample s;
      s.key = fmt::format("{:08d}", result.samples);
      s.members = t->second;
      s.members["unwrap.png"] = encode_png(in.unwrap);
      s.members["confidence.png"] = encode_png(in.confidence);
      s.members["mm_albedo.png"] = encode_png(to_srgb(in.mm.albedo));
      s.members["mm_normal.png"] = encode_png(in.mm.normal);
      s.members["mm_position.png"] = encode_png(in.mm.position, 16);
      s.members["json"] = nlohmann::json{{"subject", subject},
                                         {"face", b.keys[0]},
                                         {"style", meta.value("style", "")},
                                         {"image", o.image},
                                         {"bareskin", bool(G)},
                                         {"coefficients_from", c.extra.at("coefficients_from")},
                                         {"face_mask", o.face_masks},
                                         {"unwrap", {{"psnr_db_vs_truth", psnr}}},
                                         {"mm_position", {{"offset_mm", in.mm.position_offset},
                                                          {"scale_mm", in.mm.position_scale},
                                                          {"decode", "mm = offset + scale * value"}}}}
                               .dump();
      writer.write(s);
      subjects.insert(subject);
      ++result.samples;
    }
    shards::Manifest m;
    m.shards = writer.finish();
    if (result.samples == 0)
      throw InvalidInput(o.faces, "holds no face of a subject in " + o.textures,
                         "give the faces and the texture split of the same subjects");
    result.subjects = int64_t(subjects.size());
    result.unwrap_psnr_db = psnr_sum / double(std::max<int64_t>(1, result.samples));
    m.metadata = {{"generator", "bareskin texgen run-dataset"},
                  {"kind", "texture"},
                  {"faces", o.faces},
                  {"textures", o.textures},
                  {"image", o.image},
                  {"bareskin", bool(G)},
                  {"coefficients_from", F ? "F" : "mm-fit"}, {"bareskin_run", o.bareskin}, {"teacher", o.teacher},
                  {"input_res", o.input_res},
                  {"face_masks", o.face_masks},
                  {"samples", result.samples},
                  {"subjects", std::vector<std::string>(subjects.begin(), subjects.end())},
                  {"unwrap_psnr_db", result.unwrap_psnr_db}};
    shards::write_manifest(out.path(), m);
  }
  out.commit();
  return result;
}

}  // namespace bareskin::texture
