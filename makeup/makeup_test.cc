// makeup apply on a small avatar folder (the test template's mesh, procedural maps): no colour outside a kept
// region's feathered border, colour inside it, every bad input refused before any output; looks' JSON and its errors;
// the SH lights (environment round trip, the white furnace, the key light recovered); the four-map render.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <functional>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "core/test_util.h"
#include "makeup/apply.h"
#include "makeup/extract.h"
#include "makeup/relight.h"
#include "morphable/coefficients.h"
#include "render/sh.h"
#include "template/template_face.h"

namespace fs = std::filesystem;

namespace bareskin::looks {
namespace {

constexpr int kMap = 256;

// Skin with detail (a pattern every texel differs by), flat normals, mid roughness and specular.
Image skin_diffuse(int n) {
  Image d(n, n, 3, ColorSpace::sRGB);
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const float t = 0.04f * std::sin(0.37f * float(x)) * std::cos(0.23f * float(y));
      d.at(x, y, 0) = 0.78f + t;
      d.at(x, y, 1) = 0.6f + t;
      d.at(x, y, 2) = 0.52f + t;
    }
  return d;
}

void write_maps(const std::string& dir, int n, const std::string& suffix) {
  write_image(dir + "/maps/diffuse" + suffix + ".png", skin_diffuse(n));
  Image normal(n, n, 3, ColorSpace::Data);
  for (size_t i = 0; i < normal.pixels.size(); i += 3) normal.pixels[i] = normal.pixels[i + 1] = 0.5f, normal.pixels[i + 2] = 1;
  write_image(dir + "/maps/normal" + suffix + ".png", normal);
  write_image(dir + "/maps/roughness" + suffix + ".png", Image(n, n, 1, ColorSpace::Data, 0.5f));
  write_image(dir + "/maps/specular" + suffix + ".png", Image(n, n, 1, ColorSpace::Data, 0.5f));
}

// An avatar folder as bareskin run writes it, on the test template's mesh.
std::string make_avatar(const std::string& dir, bool hr) {
  make_directories(dir + "/maps");
  const TemplateFace face = read_template_folder(BARESKIN_TEMPLATE_DIR);
  write_mesh(dir + "/mesh.obj", face.mesh);
  write_maps(dir, kMap, "");
  if (hr) write_maps(dir, 2 * kMap, "_hr");
  Coefficients c;
  c.alpha = c.beta = c.delta = Eigen::VectorXd::Zero(1);
  c.gamma = sh_from_direction({0.3, 0.4, 1}, {0.9, 0.85, 0.8});
  write_coefficients(dir + "/coefficients.json", c);
  write_file_atomic(dir + "/bare.png", "not read, only copied");
  return dir;
}

struct Scratch {
  std::string dir = ::testing::TempDir() + "makeup_test_" + std::to_string(::getpid());
  Scratch() { fs::create_directories(dir); }
  ~Scratch() { fs::remove_all(dir); }
};

ApplyOptions options(const std::string& avatar, const std::string& out, const std::string& look, const std::string& regions) {
  ApplyOptions o;
  o.avatar = avatar;
  o.output = out;
  o.looks = look;
  o.regions = regions;
  o.template_dir = BARESKIN_TEMPLATE_DIR;
  o.preview_size = 96;
  return o;
}

TEST(MakeupLooks, BuiltinsParseAndBadLooksNameTheKey) {
  for (const auto& name : builtin_names()) EXPECT_FALSE(load_look(name).layers.layers.empty()) << name;
  auto j = load_look("red_lips").source;
  j["layers"][0]["opasity"] = 0.5;
  try {
    parse_look(j, "mine.json");
    FAIL() << "an unknown key was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("layers[0].opasity"), std::string::npos) << e.what();
  }
  j = load_look("red_lips").source;
  j["layers"][0]["region"] = "ears";
  EXPECT_THROW(parse_look(j, "mine.json"), InvalidInput);
  j = load_look("red_lips").source;
  j["layers"][0]["shade"] = "ultraviolet";
  EXPECT_THROW(parse_look(j, "mine.json"), InvalidInput);
  j = load_look("red_lips").source;
  j["layers"][0]["opacity"] = 1.5;
  EXPECT_THROW(parse_look(j, "mine.json"), InvalidInput);
  EXPECT_THROW(parse_region_list("lips,ears"), InvalidInput);
  const auto glam = load_look("glam").layers;
  const auto lips = restrict_regions(glam, parse_region_list("lips"));
  ASSERT_EQ(lips.layers.size(), 2u);  // lipstick and gloss
  for (const auto& l : lips.layers) EXPECT_TRUE(l.region == makeup::Region::Lips || l.region == makeup::Region::LipCentre);
}

// --region lips on the glam look: every texel beyond the lip layers' feathered border keeps its exact bytes (at the
// layer's size; the ×2 maps sample the layer bilinearly, so one layer texel more), the lips change.
TEST(MakeupApply, RegionDoesNotLeakAndPaintsInside) {
  Scratch s;
  const std::string avatar = make_avatar(s.dir + "/avatar", true);
  apply_command(options(avatar, s.dir + "/out", "glam", "lips"));
  const TemplateFace face = read_template_folder(BARESKIN_TEMPLATE_DIR);
  const makeup::MakeupRegions regions = makeup::makeup_regions(face, kMap);
  const auto layers = restrict_regions(load_look("glam").layers, parse_region_list("lips"));
  for (const std::string suffix : {"", "_hr"}) {
    const Image before = read_image(avatar + "/maps/diffuse" + suffix + ".png");
    const Image after = read_image(s.dir + "/out/maps/diffuse" + suffix + ".png");
    ASSERT_EQ(before.width, after.width);
    const int scale = before.width / kMap;
    const double slack = suffix.empty() ? 0 : 1.5 * regions.mm_per_texel;
    int64_t outside = 0, leaked = 0, inside = 0, changed = 0;
    for (int y = 0; y < before.height; ++y)
      for (int x = 0; x < before.width; ++x) {
        double margin = 1e9;  // mm beyond the nearest kept layer's feathered border
        for (const auto& l : layers.layers)
          margin = std::min(margin, double(regions[l.region].at(x / scale, y / scale)) - l.offset_mm - 0.5 * l.feather_mm);
        bool differs = false;
        for (int k = 0; k < 3; ++k) differs |= before.at(x, y, k) != after.at(x, y, k);
        if (margin > slack) {
          ++outside;
          leaked += differs;
        } else if (double(regions[makeup::Region::Lips].at(x / scale, y / scale)) < -0.5) {
          ++inside;
          changed += differs;
        }
      }
    EXPECT_GT(outside, 1000) << suffix;
    EXPECT_EQ(leaked, 0) << suffix << ": texels changed outside the lips' feathered border";
    EXPECT_GT(inside, 20) << suffix;
    EXPECT_GT(double(changed), 0.95 * double(inside)) << suffix;
  }
  for (const char* f : {"avatar.glb", "look.json", "makeup_layer.png", "before_after.png", "preview_light1.png",
                        "bare.png", "coefficients.json", "makeup_report.json", "mesh.obj"})
    EXPECT_TRUE(fs::exists(s.dir + "/out/" + f)) << f;
}

TEST(MakeupApply, AllLooksGiveOneFolderEach) {
  Scratch s;
  const std::string avatar = make_avatar(s.dir + "/avatar", false);
  const auto report = apply_command(options(avatar, s.dir + "/all", "all", ""));
  EXPECT_EQ(report["looks"].size(), builtin_names().size());
  for (const auto& name : builtin_names()) {
    EXPECT_TRUE(fs::exists(s.dir + "/all/" + name + "/avatar.glb")) << name;
    const Image sheet = read_image(s.dir + "/all/" + name + "/before_after.png");
    EXPECT_EQ(sheet.width, 3 * 96 + 4 * 4) << name;
  }
}

TEST(MakeupApply, BadInputLeavesNoOutput) {
  Scratch s;
  const std::string avatar = make_avatar(s.dir + "/avatar", false);
  const std::string out = s.dir + "/out";
  const auto bad_option = [&](const std::function<void(ApplyOptions&)>& change, const std::string& flag) {
    ApplyOptions o = options(avatar, out, "natural", "");
    change(o);
    try {
      apply_command(o);
      ADD_FAILURE() << flag << " was accepted";
    } catch (const InvalidInput& e) {
      EXPECT_NE(std::string(e.what()).find(flag), std::string::npos) << e.what();
    }
  };
  bad_option([](ApplyOptions& o) { o.preview_size = 0; }, "--preview-size");
  bad_option([](ApplyOptions& o) { o.max_layer_size = 100000; }, "--max-layer-size");
  bad_option([](ApplyOptions& o) { o.output.clear(); }, "-o");
  EXPECT_THROW(apply_command(options(avatar, out, "natural", "lips,ears")), InvalidInput);
  EXPECT_THROW(apply_command(options(avatar, out, "no_such_look", "")), InvalidInput);
  EXPECT_THROW(apply_command(options(avatar, out, "smoky_eyes", "lips")), InvalidInput);  // keeps no layer
  fs::remove(avatar + "/maps/roughness.png");
  try {
    apply_command(options(avatar, out, "natural", ""));
    FAIL() << "a missing map was accepted";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("roughness.png"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(out));
}

// A look read back off a made-up map (makeup/extract.h) on synthetic truth: looks texgen faces draws (its sampler,
// heavy and dramatic styles), applied to the test skin; the extracted look, applied to the same skin, must give each
// painted region's colour closer to the truth than the mean look does (per texel the mean of the seven built-in
// looks' results), and the extracted JSON must be a look `makeup apply` takes.
TEST(MakeupExtract, ExtractedLookBeatsTheMeanLook) {
  const TemplateFace face = read_template_folder(BARESKIN_TEMPLATE_DIR);
  const makeup::MakeupRegions regions = makeup::makeup_regions(face, kMap);
  const Image bare = to_linear(skin_diffuse(kMap));
  const Eigen::Vector3f skin = makeup::skin_tone(regions, bare);
  const auto made_up = [&](const makeup::MakeupLook& look) {
    Image m = bare;
    makeup::apply_makeup(makeup::paint(regions, look, skin), m, nullptr, nullptr);
    return m;
  };
  Image mean(kMap, kMap, 3, ColorSpace::Linear);
  for (const auto& name : builtin_names()) {
    const Image m = made_up(load_look(name).layers);
    for (size_t i = 0; i < mean.pixels.size(); ++i) mean.pixels[i] += m.pixels[i] / float(builtin_names().size());
  }
  int compared = 0;
  for (const auto style : {makeup::MakeupStyle::Heavy, makeup::MakeupStyle::Dramatic, makeup::MakeupStyle::Natural})
    for (uint64_t seed : {3, 11}) {
      std::mt19937_64 rng(seed);
      const makeup::MakeupLook truth = makeup::sample_look(style, rng);
      const Image made = made_up(truth);
      const nlohmann::json j = extract_look(regions, made, bare, nullptr);
      const Look extracted = parse_look(j, "extracted");  // what makeup apply --look reads
      ASSERT_FALSE(extracted.layers.layers.empty()) << j.dump();
      const Image again = made_up(extracted.layers);
      for (const auto r : {makeup::Region::Lips, makeup::Region::Lids, makeup::Region::Brows, makeup::Region::Cheeks}) {
        bool painted = false;
        for (const auto& l : truth.layers) painted = painted || l.region == r;
        if (!painted) continue;
        const double ours = makeup::mean_delta_e(regions, r, made, again),
                     baseline = makeup::mean_delta_e(regions, r, made, mean);
        EXPECT_LT(ours, baseline) << makeup::to_string(style) << " seed " << seed << " " << makeup::to_string(r)
                                  << "\n" << j.dump();
        std::printf("extract %s seed %d %s: ΔE extracted %.2f, mean look %.2f\n", makeup::to_string(style), int(seed),
                    makeup::to_string(r), ours, baseline);
        ++compared;
      }
    }
  EXPECT_GE(compared, 12);
}

TEST(Light, EnvironmentRoundTripFurnaceAndKey) {
  ShLight g = sh_from_direction({0.3, 0.5, 1}, {1.0, 0.8, 0.6});
  ShLight lit = g;  // with ambient, so that the deconvolved radiance stays ≥ 0
  for (int c = 0; c < 3; ++c) lit[size_t(9 * c)] += 1.0 / sh_scales().k0;
  const ShLight back = sh_from_environment(environment_from_sh(lit, 256));
  for (size_t i = 0; i < 27; ++i) EXPECT_NEAR(back[i], lit[i], 2e-3 * (1 + std::abs(lit[i]))) << i;
  Image white(64, 32, 3, ColorSpace::Linear, 1.0f);
  const ShLight w = sh_from_environment(white);
  for (const Eigen::Vector3d& n : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, -1, 0)})
    EXPECT_NEAR(sh_irradiance(n, w.data())[1], 1.0, 2e-3);
  const KeyLight key = dominant_light(g);
  EXPECT_LT((key.direction - Eigen::Vector3d(0.3, 0.5, 1).normalized()).norm(), 1e-9);
  EXPECT_NEAR(key.intensity[0], 1.0, 1e-9);
  EXPECT_NEAR(key.intensity[2], 0.6, 1e-9);
  const Eigen::Vector3d l = Eigen::Vector3d(0.3, 0.5, 1).normalized();
  EXPECT_GT(sh_irradiance(l, g.data())[0], 0.85);  // order-2 clamped cosine facing the light
  EXPECT_LT(std::abs(sh_irradiance(-l, g.data())[0]), 0.1);
}

TEST(Relight, FurnaceKeepsAlbedoAndTheKeyLightMovesTheHighlight) {
  Scratch s;
  const std::string avatar = make_avatar(s.dir + "/avatar", false);
  const Image white(64, 32, 3, ColorSpace::Linear, 1.0f);
  write_image(s.dir + "/white.exr", white);
  RelightOptions o;
  o.avatar = avatar;
  o.size = 128;
  o.env = s.dir + "/white.exr";
  const Frame furnace = relight(o);
  double worst = 0;
  int covered = 0;
  for (size_t i = 0; i < furnace.mask.pixels.size(); ++i)
    if (furnace.mask.pixels[i] > 0) {
      ++covered;  // a uniform light has no key: no specular, colour = albedo
      for (int k = 0; k < 3; ++k)
        worst = std::max(worst, double(std::abs(furnace.colour.pixels[3 * i + k] - furnace.albedo.pixels[3 * i + k])));
    }
  EXPECT_GT(covered, 2000);
  EXPECT_LT(worst, 5e-3);
  o.env.clear();
  auto mean_x = [&](const std::string& dir) {  // brightness-weighted column of the render
    o.direction = dir;
    const Frame f = relight(o);
    double sx = 0, sw = 0;
    for (int y = 0; y < f.colour.height; ++y)
      for (int x = 0; x < f.colour.width; ++x) {
        const double w = f.colour.at(x, y, 1);
        sx += w * x;
        sw += w;
      }
    return sx / sw;
  };
  // +x is the face's left, which the front camera shows on the image's right.
  EXPECT_GT(mean_x("1,0,0.4"), mean_x("-1,0,0.4") + 5);
  o.direction = "0,0,0";
  EXPECT_THROW(relight(o), InvalidInput);
  o.direction = "1,0";
  EXPECT_THROW(o.check(), InvalidInput);
  o.direction = "1,0,0";
  o.check();
  for (const auto& change : std::vector<std::function<void(RelightOptions&)>>{
           [](RelightOptions& r) { r.size = 8; }, [](RelightOptions& r) { r.view = "30"; },
           [](RelightOptions& r) { r.ambient = -1; }, [](RelightOptions& r) { r.export_width = 63; },
           [&](RelightOptions& r) { r.env = s.dir + "/white.exr"; }}) {  // with --direction: two lights
    RelightOptions r = o;
    change(r);
    EXPECT_THROW(r.check(), InvalidInput);
    EXPECT_THROW(relight(r), InvalidInput);
  }
  o.direction.clear();
  write_file_atomic(s.dir + "/bad.exr", "not an image");
  o.env = s.dir + "/bad.exr";
  EXPECT_THROW(relight(o), InvalidInput);
}

}  // namespace
}  // namespace bareskin::looks
