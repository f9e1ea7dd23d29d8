// bareskin evaluate: the paper's Table 1 protocol on held-out faces (avatar/avatar.h; docs/texture.md).
#include <iostream>
#include <memory>

#include "apps/cli.h"
#include "apps/detector.h"
#include "apps/device_flag.h"
#include "core/error.h"
#include "core/parallel.h"
#include "avatar/avatar.h"
#include "training/device.h"

namespace bareskin::cli {

std::function<void()> setup_evaluate_command(CLI::App& app, const Globals& globals) {
  struct Options {
    std::string model, texture, bareskin, teacher, device = "cpu";
    std::vector<std::string> upscale;
    texture::EvaluateOptions evaluate;
    bool no_face_masks = false;
  };
  auto opt = std::make_shared<Options>();
  app.add_option("--faces", opt->evaluate.faces, "Held-out faces split (texgen faces: makeup, before, json)")
      ->required();
  app.add_option("--textures", opt->evaluate.textures,
                 "Texture split of the same subjects: the true maps (column b) and the true high-resolution diffuse");
  app.add_option("-o,--output", opt->evaluate.output, "Report folder: table.md, table.csv, per_sample.csv, charts")
      ->required();
  app.add_option("--model", opt->model, "Morphable model (model.safetensors)")->required();
  app.add_option("--texture", opt->texture, "pix2pixHD run (bareskin train texture)")->required();
  app.add_option("--upscale", opt->upscale, "SRGAN runs; the diffuse one is compared with bicubic")->expected(0, -1);
  app.add_option("--bareskin", opt->bareskin, "BareSkinNet run: the 'with' column")->required();
  app.add_option("--teacher", opt->teacher, "Reconstruction net F (bareskin train recon run) for the coefficients; "
                                            "without it mm-fit");
  app.add_option("--max-samples", opt->evaluate.max_samples, "At most this many samples (0: all)")
      ->capture_default_str();
  app.add_flag("--no-face-masks", opt->no_face_masks,
               "Unwrap the whole face image (default: each sample's face.png, the face less its occluders, masks its "
               "unwraps, as `run --face-mask` does)");
  app.add_option("--input-res", opt->evaluate.avatar.input_res, "UV size of the unwrap (0: the texture run's size)")
      ->capture_default_str();
  add_device_option(app, opt->device);
  app.footer("Example: bareskin evaluate --faces faces/test --textures textures/test --model model.safetensors "
             "--texture runs/tex --upscale runs/up --bareskin runs/bsn -o report/table1");
  return [opt, &globals] {
    set_torch_threads(globals);
    opt->device = parse_device(opt->device).str();
    keep_freed_memory();
    opt->evaluate.face_masks = !opt->no_face_masks;
    const MorphableModel model = read_model(opt->model);
    const auto nets = texture::load_avatar_nets(opt->model, opt->texture, opt->upscale, opt->device, opt->teacher);
    const auto G = texture::load_demakeup(opt->bareskin, opt->device);
    const auto summary = texture::evaluate_table1(opt->evaluate, model, nets, G);
    if (!globals.quiet())
      std::cerr << "wrote " << opt->evaluate.output << ": " << summary.value("improved_of_12", 0)
                << " of 12 figures of column (a) and " << summary.value("improved_of_12_same_pipeline", 0)
                << " of 12 of column (a') improve with BareSkinNet\n";
  };
}

}  // namespace bareskin::cli
