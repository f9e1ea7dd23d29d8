// The light files of an avatar folder, for engines: a fitted SH light as light_sh.json (27 numbers, channel-major) and
// as light_env.exr (the equirectangular radiance whose irradiance it is: light.h's environment_from_sh). Written by
// `bareskin run` into every avatar folder and by `relight --export-light`. docs/relight.md.
#pragma once
#include <string>

#include "render/light.h"

namespace bareskin {

constexpr int kLightEnvWidth = 64;  // light_env.exr: 64 × 32

// Writes dir/light_sh.json and dir/light_env.exr (width × width/2, linear float), each atomically.
void write_light_files(const std::string& dir, const ShLight& light, int width = kLightEnvWidth);

}  // namespace bareskin
