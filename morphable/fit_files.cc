// `bareskin mm-fit` on files (fit.h's fit_files): the image, its landmarks and the model read, the two fits, the
// coefficient file and the trace written.
#include <spdlog/spdlog.h>

#include <chrono>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/landmarks.h"
#include "morphable/fit.h"

namespace bareskin {

void FitFilesOptions::check() const {
  if (image.empty() || model.empty() || landmarks.empty())
    throw InvalidInput("mm-fit", "needs an image, --model and --landmarks", "see mm-fit --help");
  if (view != "front" && view != "left" && view != "right")
    throw InvalidInput("--view", "'" + view + "' is not front, left or right", "e.g. --view front");
  fit.check();
  if (!no_photometric) photo.check();
}

void fit_files(FitFilesOptions o) {
  o.check();
  check_output_file(o.output);
  check_output_apart(o.output, {o.image, o.model, o.landmarks, o.skin_mask});
  if (!o.trace.empty()) {
    check_output_file(o.trace);
    check_output_apart(o.trace, {o.image, o.model, o.landmarks, o.skin_mask, o.output});
  }
  const ImageFileInfo info = probe_image(o.image);
  if (info.width != info.height) throw InvalidInput(o.image, "is not square", "give the square crop");
  const Landmarks lm = read_image_landmarks(o.landmarks, info.width, info.height);
  const MorphableModel model = read_model(o.model);
  const Camera camera = view_camera(o.view, info.width, Eigen::Vector3d::Zero());  // the model sits at the origin
  const auto t0 = std::chrono::steady_clock::now();
  const LandmarkFit fit = fit_landmarks(model, lm.points, camera, o.fit);
  PhotometricFit photo;
  if (!o.no_photometric) {
    Image image = read_image(o.image);
    if (image.color_space == ColorSpace::sRGB) image = to_linear(image);
    const Mesh posed = posed_mesh(model, to_coefficients(fit));
    Image skin;
    if (!o.skin_mask.empty()) {
      skin = read_image(o.skin_mask);
      if (skin.width != info.width || skin.height != info.height) {
        throw InvalidInput(o.skin_mask, "is " + std::to_string(skin.width) + "x" + std::to_string(skin.height) +
                                            ", the image " + std::to_string(info.width) + "x" + std::to_string(info.height),
                           "give a mask of the photo's size");
      }
      o.photo.skin_mask = &skin;
    }
    photo = fit_photometric(model, posed, camera, image, o.photo);
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Coefficients c = to_coefficients(fit);
  c.extra = {{"landmark_rms_px", fit.rms_px},
             {"iterations", fit.iterations},
             {"seconds", seconds},
             {"view", o.view},
             {"image_size", info.width},
             {"terms", o.no_photometric ? "landmarks + regularisation"
                                        : "landmarks + regularisation, then photometric (delta, gamma)"}};
  if (!o.no_photometric) {
    c.delta = photo.delta;
    c.gamma = photo.gamma;
    c.extra["photometric_psnr_db"] = photo.psnr_db;
    c.extra["photometric_pixels"] = photo.pixels;
  }
  write_coefficients(o.output, c);
  if (!o.trace.empty()) write_fit_trace(o.trace, fit, photo);
  spdlog::info("mm-fit: {} identity and {} expression components, landmark RMS {:.3f} px after {} iterations; "
               "photometric PSNR {:.1f} dB over {} pixels ({:.2f} s) -> {}",
               fit.alpha.size(), fit.beta.size(), fit.rms_px, fit.iterations, photo.psnr_db, photo.pixels, seconds,
               o.output);
}

}  // namespace bareskin
