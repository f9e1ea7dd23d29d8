// `uvtools mask`: 2D face-parsing labels (CelebAMask-HQ's 19 classes) → a UV mask of the face surface that is seen and
// not covered (by hair, glasses, a hat, a hand, ...), through `unwarp`. No real label set is available here, so
// synthetic occluders can be drawn in image space from the projected iBUG-68 landmarks with random shapes: a hair
// fringe, glasses, a hand, a hat brim — the occlusion augmentation of `texgen make-dataset`.
#pragma once
#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "render/camera.h"

namespace bareskin {

struct RasterOutput;  // render/rasterize.h

// CelebAMask-HQ label indices, plus 19 for a hand (which that set does not label).
enum FaceLabel : uint8_t {
  kBackground = 0, kSkin = 1, kNose = 2, kGlasses = 3, kLeftEye = 4, kRightEye = 5, kLeftBrow = 6, kRightBrow = 7,
  kLeftEar = 8, kRightEar = 9, kMouth = 10, kUpperLip = 11, kLowerLip = 12, kHair = 13, kHat = 14, kEarring = 15,
  kNecklace = 16, kNeck = 17, kCloth = 18, kHand = 19
};

// The face surface itself (skin, nose, eyes, brows, mouth, lips): what the UV mask keeps.
bool is_face_surface(uint8_t label);

struct LabelImage {
  int width = 0, height = 0;
  std::vector<uint8_t> label;  // row-major
};

enum class Occluder { Hair, Glasses, Hand, Hat };
std::vector<Occluder> parse_occluders(const std::string& list);  // "hair,glasses,hand,hat"; InvalidInput otherwise
const char* to_string(Occluder o);

// Paints an occluder over `labels`, shaped and placed at random (from `rng`) relative to the 68 landmarks in pixels.
void draw_occluder(LabelImage& labels, Occluder occluder, const std::vector<Eigen::Vector2d>& landmarks, std::mt19937_64& rng);

// A label image from a one-channel image of class indices (index = value * 255): InvalidInput naming `source` for more
// channels or a label above 19. And back (8-bit data).
LabelImage label_image(const Image& img, const std::string& source);
Image to_image(const LabelImage& labels);

// Synthetic labels: the mesh as the camera sees it (skin where it covers, background elsewhere), covered by the
// occluders drawn at random (seeded) around the projected landmark vertices. InvalidInput for a landmark vertex
// outside the mesh.
LabelImage synthetic_labels(const Mesh& mesh, const Camera& camera, const std::vector<int>& landmark_vertices,
                            const std::vector<Occluder>& occluders, uint64_t seed);

// The UV mask (size x size, 1 = face surface seen and uncovered) of a label image through the mesh and camera.
// InvalidInput when the labels' size is not the camera's. `uv_raster`: rasterize_uv(mesh, size) when the caller has
// it (UnwarpOptions::uv_raster).
std::vector<uint8_t> uv_face_mask(const LabelImage& labels, const Mesh& mesh, const Camera& camera, int size,
                                  int64_t* kept = nullptr, const RasterOutput* uv_raster = nullptr);

}  // namespace bareskin
