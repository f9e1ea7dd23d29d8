// Tests of the scan library share the small template made by the ctest fixture (6k vertices), read once.
#pragma once
#include <string>

#include "core/test_util.h"
#include "template/template_face.h"

namespace bareskin::testing {

inline const TemplateFace& test_template() {
  static const TemplateFace face = read_template(std::string(BARESKIN_TEMPLATE_DIR) + "/face.obj",
                                                 std::string(BARESKIN_TEMPLATE_DIR) + "/landmarks.json");
  return face;
}

}  // namespace bareskin::testing
