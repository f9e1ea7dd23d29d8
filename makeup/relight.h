// `bareskin relight`: an avatar folder rendered with its four maps (render/pbr.h) under a light of the user's
// choosing: an SH file (27 numbers, as `render --sh` reads), an HDR environment (equirectangular, through its SH
// projection), a key light direction, or by default the light the photo was fitted with (coefficients.json). Also
// exports that fitted light as SH JSON and as a small equirectangular EXR for engines. docs/relight.md.
#pragma once
#include <string>

#include "core/image.h"
#include "render/light_files.h"
#include "render/pbr.h"

namespace bareskin::looks {


struct RelightOptions {
  std::string avatar, output;  // avatar folder; output image (.png, .exr, ...)
  std::string light;           // --light sh.json
  std::string env;             // --env hdr.exr
  std::string direction;       // --direction x,y,z (model frame, towards the light)
  double intensity = 1.0;      // key light intensity (--direction)
  double ambient = 0.3;        // uniform light added to a key light (--direction)
  std::string view = "0,0";    // yaw,pitch in degrees
  int size = 1024;
  std::string export_light;    // a folder: light_sh.json + light_env.exr of the photo's fitted light
  int export_width = kLightEnvWidth;  // width of the exported equirectangular map
  // InvalidInput naming the flag: more than one light, a bad number or size (relight_command also needs an output).
  void check() const;
};

// The light the options choose (one of light / env / direction, else the photo's): InvalidInput for more than one,
// a bad SH file, an unreadable or non-2:1 HDR, a bad direction.
PbrLight chosen_light(const RelightOptions& options);

// The render (linear RGB), and the whole command (writes the image, and the light files when asked).
Frame relight(const RelightOptions& options);
void relight_command(const RelightOptions& options);


}  // namespace bareskin::looks
