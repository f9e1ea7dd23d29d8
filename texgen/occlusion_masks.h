// Occlusion masks for texture inference (paper §5: skin masks multiplied into the unwrapped input at every step):
// UV visibility masks of a face seen in one picture and not covered. Two sources: synthetic occluders (uvtools/mask.h:
// hair, glasses, hand, hat drawn around the fitted face's landmarks) and CelebAMask-HQ label images with their photos
// (the 3DMM fitted to each photo's detected landmarks, the face-surface labels unwrapped through that fit).
#pragma once
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "morphable/coefficients.h"
#include "morphable/fit.h"
#include "morphable/model.h"
#include "texgen/texture_sample.h"
#include "uvtools/mask.h"

namespace bareskin::texgen {

struct UvMask {
  Image mask;  // size², 1 channel Data: 1 = face surface seen and uncovered
  nlohmann::json meta;  // {"source": "synthetic" | "celebamask", ...}
};

// A random non-empty subset of `occluders` (seeded) drawn over the fitted face seen by the canonical camera at
// `camera_size`, unwrapped into a size² UV mask (`uv_raster`: rasterize_uv of the model's topology at size, when the
// caller has it).
UvMask synthetic_mask(const MorphableModel& model, const Coefficients& fit, int camera_size,
                      const std::vector<Occluder>& occluders, uint64_t seed, int size,
                      const RasterOutput* uv_raster = nullptr);

// CelebAMask-HQ's layout: <dir>/CelebA-HQ-img/<id>.jpg and <dir>/CelebAMask-HQ-mask-anno/<id / 2000>/<id, 5 digits>_<part>.png.
// The photo ids with an image, ascending. InvalidInput naming the folder when either subfolder is missing or empty.
std::vector<int> celebamask_ids(const std::string& dir);

// The label image of one photo, composed from its part masks in CelebAMask-HQ's order (later parts win); parts
// without a file are absent. InvalidInput when no part exists or the parts differ in size.
LabelImage celebamask_labels(const std::string& dir, int id);

// The photo's UV mask: landmarks detected on the photo resized to the labels' size, the model's landmark fit with
// the canonical camera there, the face-surface labels unwrapped through it. InvalidInput naming the photo when no
// face is found.
UvMask celebamask_mask(const MorphableModel& model, const std::string& dir, int id, const FaceLandmarkDetector& detect,
                       const LandmarkFitOptions& fit_options, int size);

}  // namespace bareskin::texgen
