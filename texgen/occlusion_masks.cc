#include "texgen/occlusion_masks.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>

#include "core/error.h"
#include "core/image_io.h"

namespace bareskin::texgen {

namespace fs = std::filesystem;

namespace {

Image to_mask_image(const std::vector<uint8_t>& mask, int size) {
  Image img(size, size, 1, ColorSpace::Data);
  for (size_t i = 0; i < mask.size(); ++i) img.pixels[i] = mask[i] ? 1.f : 0.f;
  return img;
}

// CelebAMask-HQ's part files, in the order its own label composition applies them, with our label for each.
const std::vector<std::pair<const char*, FaceLabel>>& celebamask_parts() {
  static const std::vector<std::pair<const char*, FaceLabel>> parts = {
      {"skin", kSkin},       {"nose", kNose},       {"eye_g", kGlasses},   {"l_eye", kLeftEye},   {"r_eye", kRightEye},
      {"l_brow", kLeftBrow}, {"r_brow", kRightBrow}, {"l_ear", kLeftEar},  {"r_ear", kRightEar},  {"mouth", kMouth},
      {"u_lip", kUpperLip},  {"l_lip", kLowerLip},  {"hair", kHair},       {"hat", kHat},         {"ear_r", kEarring},
      {"neck_l", kNecklace}, {"neck", kNeck},       {"cloth", kCloth}};
  return parts;
}

std::string photo_path(const std::string& dir, int id) {
  for (const char* ext : {".jpg", ".png"}) {
    const std::string p = dir + "/CelebA-HQ-img/" + std::to_string(id) + ext;
    if (fs::exists(p)) return p;
  }
  throw InvalidInput(dir + "/CelebA-HQ-img", "has no photo " + std::to_string(id) + ".jpg", "give CelebAMask-HQ's folder");
}

}  // namespace

UvMask synthetic_mask(const MorphableModel& model, const Coefficients& fit, int camera_size,
                      const std::vector<Occluder>& occluders, uint64_t seed, int size, const RasterOutput* uv_raster) {
  BS_CHECK(!occluders.empty(), "synthetic_mask needs occluders");
  std::mt19937_64 rng(seed);
  std::vector<Occluder> chosen;
  for (Occluder o : occluders)
    if (rng() & 1) chosen.push_back(o);
  if (chosen.empty()) chosen.push_back(occluders[size_t(rng() % occluders.size())]);
  const Mesh posed = posed_mesh(model, fit);
  const Camera camera = view_camera("front", camera_size, Eigen::Vector3d::Zero(), 1000);
  const LabelImage labels = synthetic_labels(posed, camera, model.landmark_vertices, chosen, rng());
  int64_t kept = 0;
  UvMask out{to_mask_image(uv_face_mask(labels, posed, camera, size, &kept, uv_raster), size), {{"source", "synthetic"}}};
  auto names = nlohmann::json::array();
  for (Occluder o : chosen) names.push_back(to_string(o));
  out.meta["occluders"] = names;
  out.meta["texels"] = kept;
  return out;
}

std::vector<int> celebamask_ids(const std::string& dir) {
  const std::string images = dir + "/CelebA-HQ-img", anno = dir + "/CelebAMask-HQ-mask-anno";
  for (const std::string& d : {images, anno})
    if (!fs::is_directory(d))
      throw InvalidInput(d, "is missing", "give CelebAMask-HQ's folder (CelebA-HQ-img/ and CelebAMask-HQ-mask-anno/)");
  std::vector<int> ids;
  for (const auto& entry : fs::directory_iterator(images)) {
    const std::string stem = entry.path().stem().string(), ext = entry.path().extension().string();
    if ((ext == ".jpg" || ext == ".png") && !stem.empty() && stem.size() < 9 &&
        std::all_of(stem.begin(), stem.end(), [](char c) { return c >= '0' && c <= '9'; }))
      ids.push_back(std::stoi(stem));
  }
  if (ids.empty()) throw InvalidInput(images, "holds no <id>.jpg photos", "give CelebAMask-HQ's folder");
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  return ids;
}

LabelImage celebamask_labels(const std::string& dir, int id) {
  char name[32];
  LabelImage labels;
  for (const auto& [part, label] : celebamask_parts()) {
    std::snprintf(name, sizeof(name), "/%d/%05d_", id / 2000, id);
    const std::string path = dir + "/CelebAMask-HQ-mask-anno" + name + part + ".png";
    if (!fs::exists(path)) continue;
    const Image img = read_image(path);
    if (labels.width == 0) {
      labels.width = img.width;
      labels.height = img.height;
      labels.label.assign(size_t(img.width) * size_t(img.height), kBackground);
    } else if (img.width != labels.width || img.height != labels.height) {
      throw InvalidInput(path, "differs in size from the photo's other part masks", "give CelebAMask-HQ's part masks");
    }
    for (size_t i = 0; i < labels.label.size(); ++i)
      if (img.pixels[i * size_t(img.channels)] > 0.5f) labels.label[i] = label;
  }
  if (labels.width == 0)
    throw InvalidInput(dir + "/CelebAMask-HQ-mask-anno", "has no part masks for photo " + std::to_string(id),
                       "give CelebAMask-HQ's annotations, or remove the photo");
  return labels;
}

UvMask celebamask_mask(const MorphableModel& model, const std::string& dir, int id, const FaceLandmarkDetector& detect,
                       const LandmarkFitOptions& fit_options, int size) {
  const LabelImage labels = celebamask_labels(dir, id);
  if (labels.width != labels.height)
    throw InvalidInput(dir + "/CelebAMask-HQ-mask-anno", "part masks of photo " + std::to_string(id) + " are not square",
                       "give CelebAMask-HQ's annotations");
  const std::string photo = photo_path(dir, id);
  Image image = read_image(photo);
  if (image.width != image.height || image.channels < 3)
    throw InvalidInput(photo, "is not a square RGB photo", "give CelebA-HQ's photos");
  if (image.color_space == ColorSpace::Linear) image = to_srgb(image);
  image = resize_square(image, labels.width);
  const std::optional<Landmarks68> found = detect(image);
  if (!found) throw InvalidInput(photo, "no face found in the photo", "remove it from the folder, or pass --keep-going");
  const Camera camera = view_camera("front", labels.width, Eigen::Vector3d::Zero(), 1000);
  const LandmarkFit lm = fit_landmarks(model, *found, camera, fit_options);
  Coefficients c;
  c.alpha = lm.alpha;
  c.beta = lm.beta;
  c.rotation = lm.rotation;
  c.translation = lm.translation;
  const Mesh posed = posed_mesh(model, c);
  int64_t kept = 0;
  UvMask out{to_mask_image(uv_face_mask(labels, posed, camera, size, &kept), size),
             {{"source", "celebamask"}, {"photo", fs::path(photo).filename().string()}, {"id", id},
              {"landmark_rms_px", lm.rms_px}}};
  out.meta["texels"] = kept;
  return out;
}

}  // namespace bareskin::texgen
