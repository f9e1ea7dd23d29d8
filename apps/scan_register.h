// `scan register` as a library for the commands that drive it (scan register, mm-build).
#pragma once
#include <string>
#include <vector>

#include "apps/cli.h"
#include "template/template_face.h"
#include "scan/register.h"
#include "scan/uv_maps.h"

namespace bareskin::cli {

struct RegisterArgs {
  std::string template_dir = "template", scans = "scans", output = "registered";
  bool keep_going = false, no_landmarks = false;
  double heat_max_mm = 2.0;
  BakeOptions maps = [] {  // resolution 0: no texture transfer
    BakeOptions o;
    o.resolution = 1024;
    return o;
  }();
  std::string map_format = "png";
  RegisterOptions nicp;
};

// Registers every scan folder of args.scans that has no report in args.output yet (in parallel, with a progress bar;
// --keep-going collects failures), writes args.output/summary.json and returns args.output/<id> for every scan.
// Throws InvalidInput when a scan failed (after the others, with keep_going).
std::vector<std::string> register_folder(const TemplateFace& face, const RegisterArgs& args, const Globals& globals);

}  // namespace bareskin::cli
