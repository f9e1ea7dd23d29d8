// Makeup layers: regions land on the template's landmarks, the blend formula against hand-computed texels, the seeded
// style sampler, the layer's PNG form, CIELAB against published values.
#include "texgen/makeup.h"

#include <gtest/gtest.h>

#include <tuple>

#include "core/error.h"
#include "core/png.h"
#include "core/test_util.h"

namespace bareskin::makeup {
namespace {

const TemplateFace& test_face() {
  static const TemplateFace face = read_template(std::string(BARESKIN_TEMPLATE_DIR) + "/face.obj",
                                                 std::string(BARESKIN_TEMPLATE_DIR) + "/landmarks.json");
  return face;
}

constexpr int kUv = 256;

const MakeupRegions& test_regions() {
  static const MakeupRegions regions = makeup_regions(test_face(), kUv);
  return regions;
}

// A one-layer look: opacity 1, 1 mm feather, no offset.
MakeupLook one_layer(Region region, const Eigen::Vector3f& colour = {0.5f, 0.1f, 0.1f}) {
  LayerSpec l;
  l.product = "test";
  l.region = region;
  l.colour = colour;
  l.opacity = 1;
  l.feather_mm = 1;
  MakeupLook look;
  look.style = MakeupStyle::Heavy;
  look.layers.push_back(l);
  return look;
}

float alpha_at(const MakeupLayer& layer, const Eigen::Vector2d& texel) {
  return layer.colour.at(int(texel.x()), int(texel.y()), 3);
}

const Eigen::Vector3f kSkin(0.5f, 0.35f, 0.3f);

TEST(MakeupRegions, LipstickSitsOnTheLipsAndNotOnTheNose) {
  const std::vector<Eigen::Vector2d> L = landmark_texels(test_face(), kUv);
  const MakeupLayer lips = paint(test_regions(), one_layer(Region::Lips), kSkin);
  // The lip body: half way between each outer-contour landmark and the inner-contour landmark facing it.
  const std::pair<int, int> body[] = {{49, 61}, {50, 61}, {51, 62}, {52, 63}, {53, 63},
                                      {55, 65}, {56, 65}, {57, 66}, {58, 67}, {59, 67}};
  for (const auto& [outer, inner] : body) {
    EXPECT_GT(alpha_at(lips, 0.5 * (L[size_t(outer)] + L[size_t(inner)])), 0.5f) << outer << "/" << inner;
  }
  for (int k : {30, 33, 37, 44, 8, 19}) EXPECT_LT(alpha_at(lips, L[size_t(k)]), 0.01f) << "landmark " << k;
}

TEST(MakeupRegions, EyeCheekAndBrowLayersSitOnTheirLandmarks) {
  const std::vector<Eigen::Vector2d> L = landmark_texels(test_face(), kUv);
  const MakeupRegions& regions = test_regions();
  const MakeupLayer lids = paint(regions, one_layer(Region::Lids), kSkin);
  const MakeupLayer cheeks = paint(regions, one_layer(Region::Cheeks), kSkin);
  const MakeupLayer brows = paint(regions, one_layer(Region::Brows), kSkin);
  const MakeupLayer face = paint(regions, one_layer(Region::Face), kSkin);
  const double mm = 1 / regions.mm_per_texel;
  const Eigen::Vector2d down = (L[8] - L[27]).normalized();
  for (const auto& [lid, brow] : {std::pair{37, 19}, std::pair{38, 20}, std::pair{43, 23}, std::pair{44, 24}}) {
    // Lid shadow a fifth of the way from the upper lid to the brow; none inside the eye (between the lids).
    EXPECT_GT(alpha_at(lids, L[size_t(lid)] + 0.2 * (L[size_t(brow)] - L[size_t(lid)])), 0.5f) << lid;
    const Eigen::Vector2d in_eye = 0.5 * (L[size_t(lid)] + L[size_t(lid == 37   ? 41
                                                                    : lid == 38 ? 40
                                                                    : lid == 43 ? 47
                                                                                : 46)]);
    EXPECT_LT(alpha_at(lids, in_eye), 0.05f) << lid;
    EXPECT_LT(alpha_at(face, in_eye), 0.05f) << lid;
    // Brow fill on the brow (1.5 mm below its landmark line, as the skin model draws it), no lid shadow there.
    EXPECT_GT(alpha_at(brows, L[size_t(brow)] + down * 1.5 * mm), 0.5f) << brow;
    EXPECT_LT(alpha_at(face, L[size_t(brow)] + down * 1.5 * mm), 0.05f) << brow;
  }
  for (const auto& [jaw, nose, eye] : {std::tuple{2, 31, 41}, std::tuple{14, 35, 46}}) {
    const Eigen::Vector2d apple = (L[size_t(jaw)] + L[size_t(nose)] + L[size_t(eye)]) / 3;
    EXPECT_GT(alpha_at(cheeks, apple), 0.5f);
    EXPECT_GT(alpha_at(face, apple), 0.5f);
  }
  for (int k : {30, 51, 57, 8}) {
    EXPECT_LT(alpha_at(cheeks, L[size_t(k)]), 0.01f) << k;
    EXPECT_LT(alpha_at(lids, L[size_t(k)]), 0.01f) << k;
  }
  EXPECT_GT(regions.mm_per_texel, 0.2);  // a ~15 cm face chart over 256 texels
  EXPECT_LT(regions.mm_per_texel, 1.5);
}

TEST(MakeupPaint, BlendFormulaMatchesAHandComputedTexel) {
  const std::vector<Eigen::Vector2d> L = landmark_texels(test_face(), kUv);
  const MakeupRegions& regions = test_regions();
  MakeupLook look = one_layer(Region::Lips, {0.6f, 0.05f, 0.1f});
  look.layers[0].opacity = 0.6f;
  look.layers[0].finish = Finish::Matte;
  LayerSpec second = look.layers[0];
  second.colour = {0.2f, 0.3f, 0.9f};
  second.opacity = 0.5f;
  second.finish = Finish::Gloss;
  look.layers.push_back(second);
  const MakeupLayer layer = paint(regions, look, kSkin);
  // The texel deepest inside the lips (largest distance to the edge), where both layers have their full opacity.
  int bx = 0, by = 0;
  for (int y = 0; y < kUv; ++y)
    for (int x = 0; x < kUv; ++x)
      if (regions[Region::Lips].at(x, y) < regions[Region::Lips].at(bx, by)) bx = x, by = y;
  ASSERT_LT(regions[Region::Lips].at(bx, by), -1.0f);  // > feather/2 inside
  const Eigen::Vector3f bare(0.4f, 0.25f, 0.2f);
  for (int scale : {1, 2}) {  // the layer's size, and a map twice as large (bilinear lookup of a flat interior)
    Image diffuse(kUv * scale, kUv * scale, 3, ColorSpace::Linear),
        rough(kUv * scale, kUv * scale, 1, ColorSpace::Data, 0.5f),
        spec(kUv * scale, kUv * scale, 1, ColorSpace::Data, 0.3f);
    for (size_t i = 0; i < diffuse.pixels.size(); ++i) diffuse.pixels[i] = bare[int(i % 3)];
    apply_makeup(layer, diffuse, &rough, &spec);
    const int x = bx * scale + scale / 2, y = by * scale + scale / 2;
    // (0.4 * 0.4 + 0.6 * 0.6) * 0.5 + 0.2 * 0.5 = 0.36 ; (0.25*0.4 + 0.05*0.6)*0.5 + 0.3*0.5 = 0.215 ;
    // (0.2*0.4 + 0.1*0.6)*0.5 + 0.9*0.5 = 0.52
    EXPECT_NEAR(diffuse.at(x, y, 0), 0.36f, 1e-4f);
    EXPECT_NEAR(diffuse.at(x, y, 1), 0.215f, 1e-4f);
    EXPECT_NEAR(diffuse.at(x, y, 2), 0.52f, 1e-4f);
    EXPECT_NEAR(rough.at(x, y), 0.5f + 0.2f - 0.3f, 1e-4f);  // matte then gloss
    EXPECT_NEAR(spec.at(x, y), 0.3f - 0.15f + 0.35f, 1e-4f);
    // Far from the lips nothing changes, bit for bit.
    const Eigen::Vector2d nose = L[30] * scale;
    EXPECT_EQ(diffuse.at(int(nose.x()), int(nose.y()), 0), bare[0]);
    EXPECT_EQ(rough.at(int(nose.x()), int(nose.y())), 0.5f);
  }
  EXPECT_NEAR(layer.colour.at(bx, by, 3), 1 - 0.4f * 0.5f, 1e-5f);  // total alpha A = 1 - (1 - 0.6)(1 - 0.5)
}

TEST(MakeupPaint, SkinRelativeColourFollowsTheSkinAndBadLayersAreRejected) {
  const MakeupRegions& regions = test_regions();
  MakeupLook look = one_layer(Region::Face, {1.1f, 1.0f, 0.9f});
  look.layers[0].mode = ColourMode::SkinRelative;
  const MakeupLayer layer = paint(regions, look, kSkin);
  int x = 0, y = 0;
  for (int yy = 0; yy < kUv; ++yy)
    for (int xx = 0; xx < kUv; ++xx)
      if (regions[Region::Face].at(xx, yy) < regions[Region::Face].at(x, y)) x = xx, y = yy;
  EXPECT_NEAR(layer.colour.at(x, y, 0), 0.55f, 1e-5f);
  EXPECT_NEAR(layer.colour.at(x, y, 1), 0.35f, 1e-5f);
  EXPECT_NEAR(layer.colour.at(x, y, 2), 0.27f, 1e-5f);
  look.layers[0].opacity = 1.5f;
  EXPECT_THROW(paint(regions, look, kSkin), InvalidInput);
  look.layers[0].opacity = 1;
  look.layers[0].offset_mm = 20;
  EXPECT_THROW(paint(regions, look, kSkin), InvalidInput);
}

TEST(MakeupStyles, SamplerIsDeterministicPerSeedAndHonoursExclusions) {
  for (int style = 0; style < kStyleCount; ++style) {
    std::mt19937_64 a(42), b(42), c(43);
    const nlohmann::json ja = to_json(sample_look(MakeupStyle(style), a));
    EXPECT_EQ(ja, to_json(sample_look(MakeupStyle(style), b)));
    if (style != 0) {
      EXPECT_NE(ja, to_json(sample_look(MakeupStyle(style), c)));
    }
    EXPECT_EQ(ja, to_json(look_from_json(ja)));  // JSON round trip
  }
  const std::vector<MakeupStyle> allowed = select_styles(parse_styles("all"), parse_styles("dramatic"));
  ASSERT_EQ(allowed.size(), 4u);
  std::mt19937_64 rng(7);
  int counts[kStyleCount] = {};
  for (int i = 0; i < 2000; ++i) ++counts[int(sample_style(allowed, rng))];
  EXPECT_EQ(counts[int(MakeupStyle::Dramatic)], 0);
  for (MakeupStyle s : allowed) EXPECT_GT(counts[int(s)], 400) << to_string(s);
  EXPECT_EQ(parse_styles("light, heavy,light"), (std::vector<MakeupStyle>{MakeupStyle::Light, MakeupStyle::Heavy}));
  EXPECT_THROW(parse_styles("light,goth"), InvalidInput);
  EXPECT_THROW(parse_styles(""), InvalidInput);
  EXPECT_THROW(parse_styles("light,"), InvalidInput);
  EXPECT_THROW(select_styles(parse_styles("light"), parse_styles("light")), InvalidInput);
}

TEST(MakeupLayerFiles, PngFormRoundTripsWithin8Bit) {
  std::mt19937_64 rng(3);
  const MakeupLayer layer = paint(test_regions(), sample_look(MakeupStyle::Dramatic, rng), kSkin);
  const MakeupLayer back = layer_from_png_images(decode_png(encode_png(layer_png_image(layer)), "layer.png"),
                                                 decode_png(encode_png(finish_png_image(layer)), "finish.png"));
  Image a(kUv, kUv, 3, ColorSpace::Linear, 0.3f), b = a;
  apply_makeup(layer, a, nullptr, nullptr);
  apply_makeup(back, b, nullptr, nullptr);
  float worst = 0;
  for (size_t i = 0; i < a.pixels.size(); ++i) worst = std::max(worst, std::abs(a.pixels[i] - b.pixels[i]));
  EXPECT_LT(worst, 0.02f);
  float worst_finish = 0;
  for (size_t i = 0; i < layer.finish.pixels.size(); ++i)
    worst_finish = std::max(worst_finish, std::abs(layer.finish.pixels[i] - back.finish.pixels[i]));
  EXPECT_LT(worst_finish, 0.5f / 127 + 1e-6f);
}

TEST(MakeupMeasure, CielabMatchesPublishedValues) {
  // sRGB primaries and white in CIELAB (D65): white (100, 0, 0), red (53.24, 80.09, 67.20), blue (32.30, 79.19,
  // -107.86).
  const Eigen::Vector3f white = linear_rgb_to_lab({1, 1, 1}), red = linear_rgb_to_lab({1, 0, 0}),
                        blue = linear_rgb_to_lab({0, 0, 1});
  EXPECT_NEAR(white.x(), 100, 0.01);
  EXPECT_NEAR(white.y(), 0, 0.01);
  EXPECT_NEAR(white.z(), 0, 0.01);
  EXPECT_NEAR(red.x(), 53.24, 0.02);
  EXPECT_NEAR(red.y(), 80.09, 0.02);
  EXPECT_NEAR(red.z(), 67.20, 0.02);
  EXPECT_NEAR(blue.x(), 32.30, 0.02);
  EXPECT_NEAR(blue.y(), 79.19, 0.02);
  EXPECT_NEAR(blue.z(), -107.86, 0.02);
  EXPECT_NEAR(delta_e({1, 1, 1}, {1, 0, 0}), (white - red).norm(), 1e-4);
}

}  // namespace
}  // namespace bareskin::makeup
