// Every options struct checks its own fields (check()), and the library function that takes it calls check() before
// it reads or writes anything: a bad value from any caller (a flag, a JSON file, code) is one InvalidInput line that
// names what is wrong. Here the geometry side's structs (core, render, uvtools, morphable, texgen: texgen_test links
// them all); recon/recon_test.cc has the Torch side's.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "core/mesh_io.h"
#include "core/test_options.h"
#include "core/test_util.h"
#include "morphable/fit.h"
#include "morphable/metrics.h"
#include "morphable/procrustes.h"
#include "render/preview.h"
#include "render/shade.h"
#include "texgen/contact_sheet.h"
#include "uvtools/unwarp.h"

namespace bareskin {
namespace {

namespace fs = std::filesystem;
using testing::expect_check_refuses;

TEST(OptionsCheck, GeometrySideRefusesBadValues) {
  expect_check_refuses(MeshWriteOptions{}, [](auto& o) { o.precision = 0; }, "[1, 17]");
  expect_check_refuses(ShadeOptions{}, [](auto& o) { o.albedo.x() = -0.1f; }, "albedo");
  expect_check_refuses(ShadeOptions{}, [](auto& o) { o.gamma[4] = std::nan(""); }, "non-finite");
  expect_check_refuses(PreviewOptions{}, [](auto& o) { o.size = 8; }, "--size");
  expect_check_refuses(PreviewOptions{}, [](auto& o) { o.wire_opacity = 1.5; }, "opacity");
  expect_check_refuses(UnwarpOptions{}, [](auto& o) { o.size = 0; }, "--size");
  expect_check_refuses(UnwarpOptions{}, [](auto& o) { o.depth_tolerance = 0; }, "--depth-tolerance");
  expect_check_refuses(GpaOptions{}, [](auto& o) { o.max_iterations = 0; }, "iterations");
  expect_check_refuses(GpaOptions{}, [](auto& o) { o.tolerance_mm = -1; }, "tolerance");
  expect_check_refuses(PhotometricFitOptions{}, [](auto& o) { o.noise = 0; }, "--colour-noise");
  expect_check_refuses(PhotometricFitOptions{}, [](auto& o) { o.iterations = 0; }, "iterations");
  expect_check_refuses(MetricsOptions{}, [](auto& o) { o.samples = 0; }, "--samples");
  EvaluateModelOptions evaluate;
  evaluate.model = "model.safetensors";
  evaluate.registered = "registered";
  expect_check_refuses(evaluate, [](auto& o) { o.registered.clear(); }, "--registered");
  expect_check_refuses(evaluate, [](auto& o) { o.metrics.max_held_out = 0; }, "--max-held-out");  // nested
  FitFilesOptions fit;
  fit.image = "photo.png", fit.model = "model.safetensors", fit.landmarks = "photo.json";
  expect_check_refuses(fit, [](auto& o) { o.view = "top"; }, "--view");
  expect_check_refuses(fit, [](auto& o) { o.fit.iterations = 0; }, "--iterations");  // nested
  expect_check_refuses(fit, [](auto& o) { o.photo.lighting_sd = -1; }, "--lighting-sd");
  fit.no_photometric = true;  // the photometric options are not used, so not checked
  fit.photo.lighting_sd = -1;
  EXPECT_NO_THROW(fit.check());
  expect_check_refuses(texgen::ContactSheetOptions{}, [](auto& o) { o.count = 0; }, "--count");
}

// The entry points check first: nothing is read (a missing input is not what they report) and nothing is written.
TEST(OptionsCheck, EntryPointsCheckBeforeTheyReadOrWrite) {
  const std::string dir = testing::temp_dir();
  Mesh mesh;
  mesh.V = Eigen::MatrixX3d::Identity(3, 3);
  mesh.F = Eigen::MatrixX3i(1, 3);
  mesh.F << 0, 1, 2;
  MeshWriteOptions write;
  write.precision = 40;
  EXPECT_THROW(write_mesh(dir + "/mesh.obj", mesh, write), InvalidInput);
  EXPECT_FALSE(fs::exists(dir + "/mesh.obj"));

  PreviewOptions preview;
  preview.wire_opacity = -1;
  EXPECT_THROW(render_preview(mesh, preview), InvalidInput);

  texgen::ContactSheetOptions sheet;
  sheet.tile = 8;
  EXPECT_THROW(texgen::contact_sheet(dir + "/no_such_dataset", sheet), InvalidInput);  // not IoError: never opened

  FitFilesOptions fit;
  fit.image = dir + "/missing.png", fit.model = dir + "/missing.safetensors", fit.landmarks = dir + "/missing.json";
  fit.output = dir + "/fit.json";
  fit.fit.regularisation = -1;
  EXPECT_THROW(fit_files(fit), InvalidInput);  // not IoError: no file was opened
  EXPECT_FALSE(fs::exists(fit.output));

  EvaluateModelOptions evaluate;
  evaluate.model = dir + "/missing.safetensors";
  evaluate.registered = dir;
  evaluate.metrics.samples = 0;
  EXPECT_THROW(evaluate_model(evaluate), InvalidInput);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace bareskin
