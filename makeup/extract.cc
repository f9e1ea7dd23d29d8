#include "makeup/extract.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "makeup/looks.h"
#include "template/template_face.h"

namespace bareskin::looks {
namespace {

using makeup::Region;

struct Candidate {
  const char* product;
  Region region;
  double feather_mm;
  const char* finish;
};
// Painted in this order (the order of the built-in looks).
const Candidate kCandidates[] = {{"foundation", Region::Face, 4, "matte"},  {"blush", Region::Cheeks, 12, "satin"},
                                 {"eyeshadow", Region::Lids, 4, "satin"},   {"brow", Region::Brows, 1.2, "matte"},
                                 {"eyeliner", Region::LashLine, 0.5, "satin"}, {"lipstick", Region::Lips, 1, "satin"}};

std::string hex(const Eigen::Vector3f& linear) {
  char s[8];
  int v[3];
  for (int k = 0; k < 3; ++k) v[k] = int(std::lround(255.0f * std::clamp(linear_to_srgb(linear[k]), 0.0f, 1.0f)));
  std::snprintf(s, sizeof s, "#%02x%02x%02x", v[0], v[1], v[2]);
  return s;
}

// The texels where candidate `c` is fully painted (its distance below −feather/2, or below 0 where that leaves too
// few), covered, outside the eyes and seen; the face's also outside every other candidate's footprint.
std::vector<size_t> core_texels(const makeup::MakeupRegions& regions, const Candidate& c, const Image* seen,
                                int min_texels) {
  const int n = regions.uv_size;
  std::vector<size_t> out;
  for (double depth : {c.feather_mm / 2, 0.0}) {
    out.clear();
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        if (regions[c.region].at(x, y) >= -depth || regions.coverage.at(x, y) <= 0 ||
            regions.exclusion.at(x, y) > 0 || (seen && seen->at(x, y) <= 0.5f))
          continue;
        bool other = false;
        for (const Candidate& o : kCandidates)
          other = other || (c.region == Region::Face && o.region != Region::Face &&
                            regions[o.region].at(x, y) < o.feather_mm / 2);
        if (!other) out.push_back(size_t(y) * size_t(n) + size_t(x));
      }
    if (int(out.size()) >= min_texels) break;
  }
  return out;
}

Image first_channels(const Image& m, int k) {
  if (m.channels == k) return m;
  Image out(m.width, m.height, k, m.color_space);
  for (size_t i = 0; i < size_t(m.width) * size_t(m.height); ++i)
    for (int c = 0; c < k; ++c) out.pixels[i * size_t(k) + size_t(c)] = m.pixels[i * size_t(m.channels) + size_t(c)];
  return out;
}

}  // namespace

std::set<Region> extract_regions() {
  std::set<Region> r;
  for (const Candidate& c : kCandidates) r.insert(c.region);
  return r;
}

void ExtractOptions::check() const {
  if (name.empty()) throw InvalidInput("--name", "is empty", "give the look a name, e.g. --name evening");
  if (!(min_delta_e >= 0 && min_delta_e <= 100))
    throw InvalidInput("--min-delta-e", "must lie in [0, 100] (mean ΔE*ab)", "use e.g. 2 (default)");
  if (min_texels < 1) throw InvalidInput("extract", "a region needs at least 1 texel", "use e.g. 12 (default)");
}

nlohmann::json extract_look(const makeup::MakeupRegions& regions, const Image& made, const Image& bare,
                            const Image* seen, const ExtractOptions& o) {
  o.check();
  const int n = regions.uv_size;
  for (const Image* m : {&made, &bare})
    if (m->width != n || m->height != n || m->channels != 3 || m->color_space != ColorSpace::Linear)
      throw InvalidInput("extract", "the made-up and bare maps must be linear RGB at the regions' size",
                         "unwrap both at the regions' size");
  if (seen && (seen->width != n || seen->height != n))
    throw InvalidInput("extract", "the seen mask must have the regions' size", "unwrap it at the regions' size");
  nlohmann::json look = {{"name", o.name}, {"layers", nlohmann::json::array()}};
  if (!o.description.empty()) look["description"] = o.description;
  Image base = bare;  // the bare skin under the layers kept so far
  for (const Candidate& c : kCandidates) {
    if (regions[c.region].empty()) continue;
    const std::vector<size_t> texels = core_texels(regions, c, seen, o.min_texels);
    if (int(texels.size()) < o.min_texels) continue;
    Eigen::Vector3d m_mean = Eigen::Vector3d::Zero(), b_mean = Eigen::Vector3d::Zero();
    double delta_e = 0;
    for (size_t t : texels) {
      const Eigen::Vector3f m(made.pixels[3 * t], made.pixels[3 * t + 1], made.pixels[3 * t + 2]),
          b(base.pixels[3 * t], base.pixels[3 * t + 1], base.pixels[3 * t + 2]);
      m_mean += m.cast<double>();
      b_mean += b.cast<double>();
      delta_e += makeup::delta_e(m, b);
    }
    m_mean /= double(texels.size());
    b_mean /= double(texels.size());
    if (delta_e / double(texels.size()) < o.min_delta_e) continue;
    // One slope s = 1 − a for the three channels: made − m̄ = s (base − b̄).
    double sxy = 0, sxx = 0;
    for (size_t t : texels)
      for (int k = 0; k < 3; ++k) {
        const double db = base.pixels[3 * t + size_t(k)] - b_mean[k];
        sxy += db * (made.pixels[3 * t + size_t(k)] - m_mean[k]);
        sxx += db * db;
      }
    const double slope = sxx > 1e-12 ? std::clamp(sxy / sxx, 0.0, 0.95) : 0.0;
    double a = 1 - slope;
    for (int k = 0; k < 3; ++k) {  // C = b̄ + (m̄ − b̄) / a must lie in [0, 1]
      const double d = m_mean[k] - b_mean[k];
      if (d < 0 && b_mean[k] > 1e-6) a = std::max(a, -d / b_mean[k]);
      if (d > 0 && b_mean[k] < 1 - 1e-6) a = std::max(a, d / (1 - b_mean[k]));
    }
    a = std::min(a, 1.0);
    Eigen::Vector3f colour;
    for (int k = 0; k < 3; ++k) colour[k] = float(std::clamp(b_mean[k] + (m_mean[k] - b_mean[k]) / a, 0.0, 1.0));
    look["layers"].push_back({{"product", c.product}, {"region", makeup::to_string(c.region)}, {"colour", hex(colour)},
                              {"opacity", std::round(a * 1000) / 1000}, {"feather_mm", c.feather_mm},
                              {"finish", c.finish}});
    // The next candidates are fitted over what the layers so far make of the bare skin.
    base = bare;
    const Look kept = parse_look(look, "extracted look");
    makeup::apply_makeup(makeup::paint(regions, kept.layers, Eigen::Vector3f::Constant(0.5f)), base, nullptr, nullptr);
  }
  return look;
}

nlohmann::json extract_command(const ExtractCommand& c) {
  c.options.check();
  if (c.output.empty()) throw InvalidInput("-o", "is missing", "give the look file to write, e.g. look.json");
  if (lower_extension(c.output) != ".json") throw InvalidInput(c.output, "is not a .json file", "give -o look.json");
  check_output_file(c.output);
  const auto read = [](const std::string& path, const char* flag, ColorSpace space) {
    if (path.empty()) throw InvalidInput(flag, "is missing", "give an unwrap in the template UV (PNG)");
    Image m = read_image(path, space);
    if (m.width != m.height || m.width < 32)
      throw InvalidInput(path, "is " + std::to_string(m.width) + "x" + std::to_string(m.height) + ", not a square UV map",
                         "give an unwrap in the template UV (bareskin demakeup's uv.png)");
    return m;
  };
  Image made = read(c.made, "--made", ColorSpace::sRGB), bare = read(c.bare, "--bare", ColorSpace::sRGB);
  if (bare.width != made.width)
    throw InvalidInput(c.bare, "is " + std::to_string(bare.width) + " wide, --made " + std::to_string(made.width),
                       "unwrap both at one --uv-size");
  for (Image* m : {&made, &bare}) {
    if (m->channels < 3) throw InvalidInput(m == &made ? c.made : c.bare, "is not RGB", "give a colour unwrap");
    m->color_space = ColorSpace::sRGB;
    *m = to_linear(first_channels(*m, 3));
  }
  Image seen;
  if (!c.seen.empty()) {
    seen = read(c.seen, "--seen", ColorSpace::Data);
    if (seen.width != made.width)
      throw InvalidInput(c.seen, "is " + std::to_string(seen.width) + " wide, --made " + std::to_string(made.width),
                         "give the mask of the same unwrap");
    seen = first_channels(seen, 1);
  }
  const TemplateFace face = read_template_folder(c.template_dir);
  const makeup::MakeupRegions regions = makeup::makeup_regions(face, made.width, extract_regions());
  nlohmann::json look = extract_look(regions, made, bare, seen.empty() ? nullptr : &seen, c.options);
  if (look["layers"].empty())
    throw InvalidInput(c.made, "differs from --bare by less than ΔE " + std::to_string(c.options.min_delta_e).substr(0, 4) +
                                   " in every region (no makeup found)",
                       "give a made-up face, or lower --min-delta-e");
  write_file_atomic(c.output, look.dump(2) + "\n");
  return look;
}

}  // namespace bareskin::looks
