#include "morphable/uv_files.h"

#include <filesystem>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/log.h"
#include "morphable/model.h"
#include "morphable/model_input.h"
#include "uvtools/mask.h"

namespace bareskin {
namespace fs = std::filesystem;

namespace {

void check_camera(const std::string& view, const std::string& camera) {
  if (view != "front" && view != "left" && view != "right")
    throw InvalidInput("--view", "is '" + view + "'", "use front, left or right");
  if (camera != "pinhole" && camera != "weak") throw InvalidInput("--camera", "is '" + camera + "'", "use pinhole or weak");
}

}  // namespace

void UnwarpFilesOptions::check() const {
  if (image.empty()) throw InvalidInput("image", "is missing", "give the render or photo to unwarp");
  if (output.empty()) throw InvalidInput("-o", "is missing", "give the UV map to write");
  check_camera(view, camera);
  unwarp.check();
}

std::string unwarp_confidence_path(const std::string& output) {
  const fs::path p(output);
  return (p.parent_path() / (p.stem().string() + "_confidence" + p.extension().string())).string();
}

UnwarpResult unwarp_files(const UnwarpFilesOptions& o) {
  o.check();
  const std::vector<std::string> inputs = {o.image, o.mesh, o.model, o.coeffs};
  check_output_apart(o.output, inputs);
  check_output_apart(unwarp_confidence_path(o.output), inputs);
  const Mesh mesh = posed_mesh(o.mesh, o.model, o.coeffs);
  const Image image = read_image(o.image);
  if (image.width != image.height)
    throw InvalidInput(o.image, "is not square", "give the square render or crop the camera was set up for");
  const Camera cam = command_camera(mesh, !o.model.empty(), o.view, o.camera, image.width);
  const UnwarpResult r = unwarp(image, mesh, cam, o.unwarp);
  const bool exr = fs::path(o.output).extension() == ".exr";
  ImageWriteOptions w;
  if (!exr) w.type = PixelType::UInt16;
  write_image(o.output, exr ? r.colour : to_srgb(r.colour), w);
  write_image(unwarp_confidence_path(o.output), r.confidence, w);
  return r;
}

void MaskFilesOptions::check() const {
  if (output.empty()) throw InvalidInput("-o", "is missing", "give the UV mask to write");
  if (labels.empty() == synthetic.empty())
    throw InvalidInput("", "give a label image or --synthetic, not both or neither", "see 'uvtools mask --help'");
  check_camera(view, camera);
  if (size < 1 || size > 16384) throw InvalidInput("--size", std::to_string(size) + " is out of range", "use 1–16384");
  if (image_size < 16 || image_size > 8192)
    throw InvalidInput("--image-size", std::to_string(image_size) + " is out of range", "use 16–8192");
}

int64_t mask_files(const MaskFilesOptions& o) {
  o.check();
  const std::vector<std::string> inputs = {o.labels, o.mesh, o.model, o.coeffs, o.landmarks};
  check_output_apart(o.output, inputs);
  if (!o.labels_out.empty()) check_output_apart(o.labels_out, inputs);
  const Mesh mesh = posed_mesh(o.mesh, o.model, o.coeffs);
  LabelImage labels;
  if (!o.labels.empty()) {
    labels = label_image(read_image(o.labels, ColorSpace::Data), o.labels);
    if (labels.width != labels.height) throw InvalidInput(o.labels, "is not square", "give the square crop");
  }
  const int image_size = o.labels.empty() ? o.image_size : labels.width;
  const Camera cam = command_camera(mesh, !o.model.empty(), o.view, o.camera, image_size);
  if (!o.synthetic.empty()) {
    const std::vector<Occluder> occluders = parse_occluders(o.synthetic);
    std::vector<int> ids;
    if (!o.landmarks.empty()) {
      ids = read_landmark_vertex_ids(o.landmarks, mesh, 68);
    } else if (!o.model.empty()) {
      ids = read_model(o.model).landmark_vertices;
    } else {
      throw InvalidInput("", "--synthetic needs --landmarks (or --model)", "pass template/landmarks.json");
    }
    labels = synthetic_labels(mesh, cam, ids, occluders, o.seed);
    if (!o.labels_out.empty()) write_image(o.labels_out, to_image(labels));
  }
  int64_t kept = 0;
  const std::vector<uint8_t> mask = uv_face_mask(labels, mesh, cam, o.size, &kept);
  Image out(o.size, o.size, 1, ColorSpace::Data);
  for (size_t i = 0; i < mask.size(); ++i) out.pixels[i] = mask[i];
  write_image(o.output, out);
  return kept;
}

}  // namespace bareskin
