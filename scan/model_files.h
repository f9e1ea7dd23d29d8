// `bareskin mm-build` on files: the scans registered first where given (scan/register_folder.h; the registered ones
// are reused), the morphable model built from the registered subjects (morphable/build.h) with the template's
// blendshapes or a given set, written with its build report (<stem>.build.json) and, when asked, its previews.
#pragma once
#include <functional>
#include <string>

#include "core/progress.h"
#include "morphable/build.h"
#include "scan/register_folder.h"

namespace bareskin {

struct ModelFilesOptions {
  std::string scans;       // scan folders to register first ("": build from `registered` alone)
  std::string registered;  // the registered subjects ("": registered/ beside the model)
  std::string output = "model.safetensors";
  std::string template_dir;  // "": the default search
  std::string blendshapes;   // "": the set made on the template; else a safetensors file of 'deltas'
  std::string export_obj;    // "" or a folder for OBJs of the mean and of ±3 sd, and appearance PNGs
  int maps_res = RegisterFolderOptions{}.maps.resolution;  // map resolution of the registration (0: no maps)
  BuildOptions build;
  std::string generator;     // the tool and its version, recorded in the model's provenance
  void check() const;        // InvalidInput naming the flag (build.check())
};

// What the command passes in: a progress callback per stage ("scan register", "mm-build"; the stage ends when its
// callback is dropped), the registration's face detector, and what to do once the scans are registered into a folder
// (the command writes its configuration there).
struct ModelFilesHooks {
  std::function<ProgressCallback(const std::string& stage)> progress;
  ScanLandmarkDetector detect;
  std::function<void(const std::string& registered)> registered;
};

// Writes options.output and its <stem>.build.json. Returns the model file's stem path (<stem>.config.json is the
// command's). InvalidInput for bad options, a registration without maps for an appearance model, and what
// register_folder and build_model refuse.
std::string build_model_files(ModelFilesOptions options, const ModelFilesHooks& hooks);

}  // namespace bareskin
