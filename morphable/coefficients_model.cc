// The coefficient file's faces through a model: posed_mesh and appearance_image (coefficients.h). Kept apart from the
// file's reader so that the reader builds without the model (tests/fuzz).
#include "morphable/coefficients.h"

namespace bareskin {

Mesh posed_mesh(const MorphableModel& model, const Coefficients& c) {
  Mesh mesh = model.topology;
  mesh.V = model.shape(c.alpha, c.beta);
  mesh.V = ((mesh.V * euler_rotation(c.rotation).transpose()).rowwise() + c.translation.transpose()).eval();
  mesh.N.resize(0, 3);
  return mesh;
}

Image appearance_image(const MorphableModel& model, const Coefficients& c) {
  if (model.appearance_resolution <= 0 || model.appearance_mean.size() == 0) return Image();
  const int R = model.appearance_resolution;
  Image img(R, R, 3, ColorSpace::Linear);
  img.pixels = model.appearance(c.delta);
  return img;
}

}  // namespace bareskin
