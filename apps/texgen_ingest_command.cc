// bareskin texgen ingest-pairs: real before/after photos into face shards (texgen/ingest.h); bareskin texgen show: a
// contact sheet of any face shard set (texgen/contact_sheet.h). docs/datasets.md.
#include <memory>

#include "apps/cli.h"
#include "apps/detector.h"
#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "texgen/contact_sheet.h"
#include "texgen/ingest.h"

namespace bareskin::cli {

std::function<void()> setup_texgen_ingest_pairs(CLI::App& texgen, const Globals& globals) {
  auto opt = std::make_shared<texgen::IngestOptions>();
  CLI::App* app = texgen.add_subcommand("ingest-pairs",
                                        "Real before/after makeup photos (paired by file name) into "
                                        "face shards: detect, 68 landmarks, 5-point alignment, masks");
  app->add_option("before", opt->before_dir, "Folder of photos without makeup")->required();
  app->add_option("after", opt->after_dir, "Folder of the same faces with makeup (same file names, any extension)")
      ->required();
  app->add_option("-o,--output", opt->output, "Output shard set (manifest.json, faces-*.tar, report.json)")->required();
  app->add_flag("--keep-going", opt->keep_going,
                "List unmatched photos and photos without a face, and skip them "
                "(default: the first one is an error)");
  app->add_option("--shard-size", opt->shard_size, "Samples per shard")->capture_default_str();
  app->add_option("--split", opt->split, "The samples' split name (their json \"split\")")->capture_default_str();
  app->footer(
      "Example:\n  bareskin texgen ingest-pairs ladn/before ladn/after -o out/real --keep-going\n"
      "docs/datasets.md describes the samples (\"has_truth\": false).");
  return [opt, app, &globals] {
    if (!app->parsed()) return;
    opt->generator = std::string("bareskin texgen ingest-pairs ") + BARESKIN_VERSION;
    opt->check();
    check_output_apart(opt->output, {opt->before_dir, opt->after_dir});
    const detect::PhotoDetector detector = photo_detector(globals);
    if (!detector)
      throw InvalidInput("texgen ingest-pairs", "this build has no face detector (no LibTorch)",
                         "use a build with the Torch side");
    ProgressBar bar = globals.progress("texgen ingest-pairs");
    const texgen::IngestReport report = texgen::ingest_pairs(*opt, detector, bar.callback());
    bar.finish();
    for (const std::string& f : report.unmatched) spdlog::warn("unmatched: {}", f);
    for (const std::string& f : report.undetected) spdlog::warn("no face: {}", f);
    spdlog::info("texgen ingest-pairs: {} of {} pairs written to {} ({} unmatched, {} without a face)", report.written,
                 report.pairs, opt->output, report.unmatched.size(), report.undetected.size());
  };
}

std::function<void()> setup_texgen_show(CLI::App& texgen, const Globals& globals) {
  auto dataset = std::make_shared<std::string>();
  auto output = std::make_shared<std::string>();
  auto opt = std::make_shared<texgen::ContactSheetOptions>();
  CLI::App* app = texgen.add_subcommand("show",
                                        "Contact sheet of a face shard set: makeup | before | bare | skin | "
                                        "landmarks, one sample a row");
  app->add_option("dataset", *dataset, "A shard set folder, a .tar shard, or a texgen faces output")->required();
  app->add_option("-o,--output", *output, "The sheet (PNG, JPEG, ...)")->required();
  app->add_option("--count", opt->count, "Samples (rows)")->capture_default_str()->check(CLI::Range(1, 10000));
  app->add_option("--tile", opt->tile, "Tile size in pixels")->capture_default_str()->check(CLI::Range(32, 2048));
  return [dataset, output, opt, app] {
    if (!app->parsed()) return;
    write_image(*output, texgen::contact_sheet(*dataset, *opt));
    spdlog::info("texgen show: {}", *output);
  };
}

}  // namespace bareskin::cli
