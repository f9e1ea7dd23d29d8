// makeup_bench TEMPLATE_DIR REGISTERED_DIR [--uv N] [--looks K] [--seed S] [--sheet OUT.png] [--sheet-subjects M]
//              [--maps DIR]
// Makeup strength: K seeded looks per style on every registered subject (their diffuse.png in the template UV), painted
// at N² and applied to the bare albedo; prints the CIELAB ΔE*ab (CIE76) between made-up and bare albedo per region
// and style (mean over the region's texels; then mean and 10th-90th percentile over the looks that paint that region)
// as a Markdown table, with the time per look (paint + apply). --sheet writes a UV sheet: M subjects (rows) × styles
// (columns); --maps writes those made-up diffuse maps as DIR/<subject>_<style>.png (for `bareskin render`).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <numeric>
#include <string>
#include <vector>

#include "core/image_io.h"
#include "template/template_face.h"
#include "texgen/makeup.h"

using namespace bareskin;
using namespace bareskin::makeup;

namespace {

// Area resample of a linear map to n² (box filter over the source texels each target texel covers).
Image resample(const Image& in, int n) {
  Image out(n, n, 3, ColorSpace::Linear);
  const double sx = double(in.width) / n, sy = double(in.height) / n;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int x0 = int(x * sx), x1 = std::max(x0 + 1, int((x + 1) * sx)), y0 = int(y * sy),
                y1 = std::max(y0 + 1, int((y + 1) * sy));
      for (int c = 0; c < 3; ++c) {
        double s = 0;
        for (int v = y0; v < y1; ++v)
          for (int u = x0; u < x1; ++u) s += in.at(u, v, c);
        out.at(x, y, c) = float(s / ((x1 - x0) * (y1 - y0)));
      }
    }
  return out;
}

struct Row {
  const char* product;
  Region region;
};
const Row kRows[] = {{"foundation", Region::Face},      {"concealer", Region::UnderEye},
                     {"contour", Region::Cheekbones},   {"blush", Region::Cheeks},
                     {"eyeshadow (lid)", Region::Lids}, {"eyeshadow (smoky)", Region::Smoky},
                     {"eyeliner", Region::LashLine},    {"brow fill", Region::Brows},
                     {"lipstick", Region::Lips},        {"paint", Region::EyePaint}};

bool paints(const MakeupLook& look, Region r) {
  for (const LayerSpec& l : look.layers)
    if (l.region == r || (r == Region::EyePaint && l.region == Region::CheekPaint)) return true;
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: makeup_bench TEMPLATE_DIR REGISTERED_DIR [--uv N] [--looks K] [--seed S] [--sheet OUT.png]\n");
    return 2;
  }
  int uv = 512, looks = 8, sheet_subjects = 2;
  uint64_t seed = 1;
  std::string sheet, maps;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string flag = argv[i], value = argv[i + 1];
    if (flag == "--uv")
      uv = std::stoi(value);
    else if (flag == "--looks")
      looks = std::stoi(value);
    else if (flag == "--seed")
      seed = std::stoull(value);
    else if (flag == "--sheet")
      sheet = value;
    else if (flag == "--sheet-subjects")
      sheet_subjects = std::stoi(value);
    else if (flag == "--maps")
      maps = value;
    else {
      std::fprintf(stderr, "unknown flag %s\n", flag.c_str());
      return 2;
    }
  }
  const std::string dir = argv[1];
  const TemplateFace face = read_template(dir + "/face.obj", dir + "/landmarks.json");
  auto t0 = std::chrono::steady_clock::now();
  const MakeupRegions regions = makeup_regions(face, uv);
  const double regions_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  std::vector<std::string> subjects;
  for (const auto& e : std::filesystem::directory_iterator(argv[2]))
    if (std::filesystem::exists(e.path() / "diffuse.png")) subjects.push_back(e.path().string());
  std::sort(subjects.begin(), subjects.end());
  if (subjects.empty()) {
    std::fprintf(stderr, "%s: no subject folder with diffuse.png\n", argv[2]);
    return 3;
  }
  // sums[row][style] over looks that paint the row's region
  std::map<std::pair<int, int>, std::vector<double>> values;
  double paint_s = 0;
  int painted = 0;
  Image sheet_image;
  if (!sheet.empty()) sheet_image = Image(uv * kStyleCount, uv * sheet_subjects, 3, ColorSpace::Linear);
  for (size_t s = 0; s < subjects.size(); ++s) {
    const Image bare = resample(to_linear(read_image(subjects[s] + "/diffuse.png")), uv);
    const Eigen::Vector3f skin = skin_tone(regions, bare);
    for (int style = 0; style < kStyleCount; ++style) {
      for (int k = 0; k < looks; ++k) {
        std::mt19937_64 rng(seed * 1000003 + s * 1009 + uint64_t(style) * 101 + uint64_t(k));
        const MakeupLook look = sample_look(MakeupStyle(style), rng);
        t0 = std::chrono::steady_clock::now();
        const MakeupLayer layer = paint(regions, look, skin);
        Image made = bare;
        apply_makeup(layer, made, nullptr, nullptr);
        paint_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        ++painted;
        for (size_t r = 0; r < std::size(kRows); ++r) {
          if (!paints(look, kRows[r].region)) continue;
          const double d = mean_delta_e(regions, kRows[r].region, bare, made);
          if (d < 0) continue;
          values[{int(r), style}].push_back(d);
        }
        if (!maps.empty() && int(s) < sheet_subjects && k == 0) {
          write_image(maps + "/" + std::filesystem::path(subjects[s]).filename().string() + "_" +
                          to_string(MakeupStyle(style)) + ".png",
                      to_srgb(made));
        }
        if (!sheet.empty() && int(s) < sheet_subjects && k == 0) {
          for (int y = 0; y < uv; ++y)
            for (int x = 0; x < uv; ++x)
              for (int c = 0; c < 3; ++c) sheet_image.at(style * uv + x, int(s) * uv + y, c) = made.at(x, y, c);
        }
      }
    }
  }
  std::printf(
      "template %lld vertices, UV %d² (%.3f mm/texel), regions %.2f s; %zu subjects × %d looks × %d styles; "
      "paint + apply %.1f ms per look\n\n",
      (long long)face.mesh.V.rows(), uv, regions.mm_per_texel, regions_s, subjects.size(), looks, kStyleCount,
      1e3 * paint_s / std::max(painted, 1));
  std::printf("ΔE*ab mean [p10–p90] over the looks that paint the region\n\n| product (region) |");
  for (int style = 1; style < kStyleCount; ++style) std::printf(" %s |", to_string(MakeupStyle(style)));
  std::printf("\n|---|");
  for (int style = 1; style < kStyleCount; ++style) std::printf("---|");
  std::printf("\n");
  for (size_t r = 0; r < std::size(kRows); ++r) {
    std::printf("| %s (%s) |", kRows[r].product, to_string(kRows[r].region));
    for (int style = 1; style < kStyleCount; ++style) {
      const auto it = values.find({int(r), style});
      if (it == values.end()) {
        std::printf(" — |");
        continue;
      }
      std::vector<double> v = it->second;
      std::sort(v.begin(), v.end());
      const double mean = std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
      std::printf(" %.1f [%.1f–%.1f] |", mean, v[size_t(0.1 * double(v.size() - 1))],
                  v[size_t(0.9 * double(v.size() - 1))]);
    }
    std::printf("\n");
  }
  if (!sheet.empty()) write_image(sheet, to_srgb(sheet_image));
  return 0;
}
