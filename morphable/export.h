// `mm-build --export-obj DIR`: a model to look at. OBJs of the mean, of +-3 sd along the first three identity
// components and +3 sd along the first two expression components; the appearance mean and +-3 sd along the first two
// appearance components as sRGB PNGs (texels outside the UV layout grey).
#pragma once
#include <string>

#include "morphable/model.h"

namespace bareskin {

void export_model_previews(const std::string& dir, const MorphableModel& model);

}  // namespace bareskin
