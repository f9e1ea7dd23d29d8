// bareskin texgen run-dataset: texture samples made the way `bareskin run` sees a face (avatar/run_dataset.h;
// docs/texture.md): faces through G and F, unwrapped, paired with their subjects' true maps.
#include <iostream>
#include <memory>

#include "apps/cli.h"
#include "apps/detector.h"
#include "apps/device_flag.h"
#include "avatar/run_dataset.h"
#include "core/parallel.h"

namespace bareskin::cli {

std::function<void()> setup_texgen_run_dataset(CLI::App& texgen, const Globals& globals) {
  struct Options {
    texture::RunDatasetOptions o;
    bool no_face_masks = false;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* app = texgen.add_subcommand("run-dataset", "Texture samples through the run pipeline: each face's photo "
                                                       "through G and F, unwrapped, with its subject's true maps");
  app->add_option("--faces", opt->o.faces, "Faces split (texgen faces: makeup.png, before.png, face.png, json)")
      ->required();
  app->add_option("--textures", opt->o.textures, "Texture split of the same subjects (texgen make-dataset): the true "
                                                 "maps")->required();
  app->add_option("-o,--output", opt->o.output, "Dataset folder (manifest.json + shards), written all or nothing")
      ->required();
  app->add_option("--model", opt->o.model, "Morphable model (model.safetensors)")->required();
  app->add_option("--bareskin", opt->o.bareskin, "BareSkinNet run (G); without it the photo is unwrapped as it is");
  app->add_option("--teacher", opt->o.teacher, "Reconstruction net F (train recon run); without it mm-fit's fitters");
  app->add_option("--image", opt->o.image, "The face image: makeup (what users give) or before (no makeup)")
      ->capture_default_str()->check(CLI::IsMember({"makeup", "before"}));
  app->add_option("--input-res", opt->o.input_res, "UV size of the inputs (the texture run's --res)")
      ->capture_default_str();
  app->add_option("--max-samples", opt->o.max_samples, "At most this many samples (0: every face with true maps)")
      ->capture_default_str();
  app->add_option("--shard-size", opt->o.shard_size, "Samples per shard")->capture_default_str();
  app->add_flag("--no-face-masks", opt->no_face_masks,
                "Unwrap the whole face image (default: each face's face.png, the face less its occluders, masks it)");
  add_device_option(*app, opt->o.device);
  app->footer("Example: bareskin texgen run-dataset --faces faces/train --textures textures/train --model "
              "model.safetensors --bareskin runs/bsn --teacher runs/F -o textures_run/train");
  return [app, opt, &globals] {
    if (!app->parsed()) return;
    set_torch_threads(globals);
    opt->o.device = parse_device(opt->o.device).str();
    keep_freed_memory();
    opt->o.face_masks = !opt->no_face_masks;
    auto bar = globals.progress("run-dataset");
    const auto r = texture::write_run_dataset(opt->o, bar.callback());
    bar.finish();
    if (!globals.quiet())
      std::cerr << "wrote " << opt->o.output << ": " << r.samples << " samples of " << r.subjects << " subjects ("
                << r.without_truth << " faces without true maps passed over); unwraps " << r.unwrap_psnr_db
                << " dB against the true diffuse where seen\n";
  };
}

}  // namespace bareskin::cli
