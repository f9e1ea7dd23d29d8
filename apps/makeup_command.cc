// bareskin makeup: looks on an avatar folder (makeup/apply.h). `list` the built-in looks and region groups, `show` a
// look's JSON (to copy and edit), `apply` a look (or several, or all) to an avatar folder, `extract` a look from a
// made-up face's unwrap and its bare skin's (makeup/extract.h).
#include <iostream>

#include "apps/cli.h"
#include "core/parallel.h"
#include "makeup/apply.h"
#include "makeup/extract.h"

namespace bareskin::cli {

std::function<void()> setup_makeup_command(CLI::App& app, const Globals& globals) {
  app.require_subcommand(1);
  CLI::App* list = app.add_subcommand("list", "The built-in looks and the region groups --region takes");
  auto show_name = std::make_shared<std::string>();
  CLI::App* show = app.add_subcommand("show", "Print a look's JSON (a built-in name or a file), to copy and edit");
  show->add_option("look", *show_name, "A built-in look or a .json file")->required();
  auto opt = std::make_shared<looks::ApplyOptions>();
  CLI::App* apply = app.add_subcommand("apply", "Put a makeup look on an avatar folder's bare maps");
  apply->add_option("avatar", opt->avatar, "An avatar folder (bareskin run's output)")->required();
  apply->add_option("--look,--looks", opt->looks,
                    "A built-in look, a look .json, a comma-separated list of them, or all (one folder per look)")
      ->capture_default_str();
  apply->add_option("--region", opt->regions, "Only these regions: lips, eyes, brows, cheeks, contour, base, paint or "
                                              "region names (comma-separated)");
  apply->add_option("-o,--output", opt->output, "The made-up avatar folder (several looks: a folder of them)")->required();
  apply->add_option("--template", opt->template_dir, "The template the avatar's model was built on (default: search)");
  apply->add_option("--preview-size", opt->preview_size, "Previews and before/after tiles, pixels")
      ->capture_default_str()->check(CLI::Range(32, 4096));
  apply->add_option("--max-layer-size", opt->max_layer_size, "Largest size the look is painted at")
      ->capture_default_str()->check(CLI::Range(32, 8192));
  apply->footer("Example:\n  bareskin makeup apply out/avatar --look red_lips -o out/avatar_red\n"
                "  bareskin makeup apply out/avatar --looks all -o out/looks\ndocs/makeup.md describes looks.");
  auto ex = std::make_shared<looks::ExtractCommand>();
  CLI::App* extract = app.add_subcommand("extract", "Read a look off a made-up face: its unwrap against the bare skin's");
  extract->add_option("--made", ex->made, "The made-up face in the template UV (sRGB PNG)")->required();
  extract->add_option("--bare", ex->bare, "Its bare skin in the same UV (BareSkinNet's, sRGB PNG)")->required();
  extract->add_option("--seen", ex->seen, "Where both are known (grey PNG, > 0.5), e.g. demakeup's uv_mask.png");
  extract->add_option("-o,--output", ex->output, "The look file to write (.json)")->required();
  extract->add_option("--name", ex->options.name, "The look's name")->capture_default_str();
  extract->add_option("--template", ex->template_dir, "The template of the UV layout (default: search)");
  extract->add_option("--min-delta-e", ex->options.min_delta_e, "A region that changes less (mean ΔE*ab) gets no layer")
      ->capture_default_str()->check(CLI::Range(0.0, 100.0));
  extract->footer("Example:\n  bareskin demakeup photo.jpg --run runs/bsn -o d\n"
                  "  bareskin demakeup photo.jpg --run runs/bsn --without-g -o d0\n"
                  "  bareskin makeup extract --made d0/uv.png --bare d/uv.png --seen d/uv_mask.png -o mine.json\n"
                  "  bareskin makeup apply out/avatar --look mine.json -o out/avatar_mine\ndocs/makeup.md.");
  return [=, &globals] {
    if (list->parsed()) {
      std::cout << "looks (bareskin makeup show NAME prints one as JSON):\n";
      for (const auto& name : looks::builtin_names())
        std::cout << "  " << name << std::string(name.size() < 12 ? 12 - name.size() : 1, ' ')
                  << looks::load_look(name).description << "\n";
      std::cout << "region groups (--region):\n";
      for (const auto& [group, regions] : looks::region_groups()) {
        std::cout << "  " << group << std::string(12 - group.size(), ' ');
        for (size_t i = 0; i < regions.size(); ++i) std::cout << (i ? ", " : "") << makeup::to_string(regions[i]);
        std::cout << "\n";
      }
      return;
    }
    if (show->parsed()) {
      std::cout << looks::load_look(*show_name, "look").source.dump(2) << "\n";
      return;
    }
    if (extract->parsed()) {
      const nlohmann::json look = looks::extract_command(*ex);
      spdlog::info("makeup extract: {} layer(s) -> {}", look["layers"].size(), ex->output);
      return;
    }
    if (!apply->parsed()) return;
    keep_freed_memory();  // 4K maps: many large buffers on two threads
    const nlohmann::json report = looks::apply_command(*opt);
    for (const auto& l : report["looks"])
      spdlog::info("makeup apply: {} ({} layers) -> {} in {:.2f} s", l["name"].get<std::string>(),
                   l["layers"].get<size_t>(), l["folder"].get<std::string>(), l["seconds_total"].get<double>());
  };
}

}  // namespace bareskin::cli
