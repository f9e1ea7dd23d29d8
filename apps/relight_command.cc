// bareskin relight: an avatar folder rendered with its four maps under a chosen light (makeup/relight.h); also exports
// the photo's fitted light as SH JSON and an equirectangular EXR.
#include "apps/cli.h"
#include "core/parallel.h"
#include "makeup/relight.h"

namespace bareskin::cli {

std::function<void()> setup_relight_command(CLI::App& app, const Globals& globals) {
  auto opt = std::make_shared<looks::RelightOptions>();
  app.add_option("avatar", opt->avatar, "An avatar folder (bareskin run's or makeup apply's output)")->required();
  app.add_option("-o,--output", opt->output, "The render (.png sRGB, .exr linear)");
  app.add_option("--light", opt->light, "SH light: a JSON list of 27 numbers, channel-major (as render --sh)");
  app.add_option("--env", opt->env, "An equirectangular HDR environment (.exr, .hdr), used through its SH projection");
  app.add_option("--direction", opt->direction, "A key light from x,y,z (model frame: +x face's left, +y up, +z front)");
  app.add_option("--intensity", opt->intensity, "The key light's intensity (--direction)")->capture_default_str();
  app.add_option("--ambient", opt->ambient, "Uniform light added to the key light (--direction)")->capture_default_str();
  app.add_option("--view", opt->view, "yaw,pitch in degrees (positive yaw shows the face's left)")->capture_default_str();
  app.add_option("--size", opt->size, "Image size in pixels")->capture_default_str();
  app.add_option("--export-light", opt->export_light, "Write the photo's fitted light here: light_sh.json, light_env.exr");
  app.add_option("--export-width", opt->export_width, "Width of light_env.exr")->capture_default_str();
  app.footer("Without --light/--env/--direction the photo's fitted light (coefficients.json) is used.\n"
             "Example:\n  bareskin relight out/avatar --direction 0.5,0.6,1 --view 30,0 -o relit.png\ndocs/relight.md.");
  return [opt] {
    keep_freed_memory();  // the render's fresh buffers in huge pages
    looks::relight_command(*opt);
    spdlog::info("relight: {}{}", opt->output, opt->export_light.empty() ? "" : " + light in " + opt->export_light);
  };
}

}  // namespace bareskin::cli
