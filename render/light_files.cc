#include "render/light_files.h"

#include <nlohmann/json.hpp>

#include "core/files.h"
#include "core/image_io.h"

namespace bareskin {

void write_light_files(const std::string& dir, const ShLight& light, int width) {
  nlohmann::json j = nlohmann::json::array();
  for (double g : light) j.push_back(g);
  write_file_atomic(dir + "/light_sh.json", j.dump() + "\n");
  ImageWriteOptions w;
  w.type = PixelType::Float;
  write_image(dir + "/light_env.exr", environment_from_sh(light, width), w);
}

}  // namespace bareskin
