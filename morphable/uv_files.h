// The files of `uvtools unwarp` and `uvtools mask` on a mesh or a posed morphable model (model_input.h): the image or
// label image read, the camera set up as `render` sets it, the UV map or mask written. The UV work itself is
// uvtools/unwarp.h and uvtools/mask.h; this file only adds the model as a source of the mesh.
#pragma once
#include <cstdint>
#include <string>

#include "uvtools/unwarp.h"

namespace bareskin {

struct UnwarpFilesOptions {
  std::string image;          // a square render or photo the mesh is fitted to
  std::string mesh;           // a mesh with UVs posed as in the image, or
  std::string model, coeffs;  // a morphable model at these coefficients
  std::string output;         // the UV map (.exr linear, .png/.tif sRGB 16-bit); <stem>_confidence beside it
  std::string view = "front";      // camera as `render --view`
  std::string camera = "pinhole";  // pinhole or weak
  UnwarpOptions unwarp;
  void check() const;  // InvalidInput naming the flag (and unwarp's check)
};
// The confidence file's path beside `output` (<stem>_confidence<ext>).
std::string unwarp_confidence_path(const std::string& output);
// Writes the UV map and its confidence. InvalidInput for a non-square image, a mesh and a model (or neither), an output
// that is an input; nothing is written then.
UnwarpResult unwarp_files(const UnwarpFilesOptions& options);

struct MaskFilesOptions {
  std::string labels;         // a label image (CelebAMask-HQ class indices, 19 = hand), or
  std::string synthetic;      // occluders drawn at random over the face as seen ("hair,glasses,hand,hat")
  std::string mesh;           // a mesh with UVs posed as in the image, or
  std::string model, coeffs;  // a morphable model at these coefficients
  std::string output;         // the UV mask (8-bit PNG: 255 = the face seen and uncovered)
  std::string landmarks;      // --synthetic: a landmark JSON with the mesh's "vertex_ids" (a model has its own)
  std::string labels_out;     // --synthetic: "" or where the label image goes (PNG)
  std::string view = "front", camera = "pinhole";
  int size = 1024;            // UV mask size
  int image_size = 512;       // the synthetic label image's size
  uint64_t seed = 1;          // the occluders' shapes
  void check() const;         // InvalidInput naming the flag
};
// Writes the mask (and the synthetic labels); returns the texels kept. InvalidInput for a label image and --synthetic
// (or neither), a non-square label image, --synthetic without landmarks, an output that is an input.
int64_t mask_files(const MaskFilesOptions& options);

}  // namespace bareskin
