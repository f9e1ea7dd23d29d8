// The network zoo: parameter counts against the reference implementations (torchvision's own count for the ResNets;
// the reference layouts rebuilt in Python torch, tests/python/torchvision_oracle.py --counts, for the others; by hand
// in the comments), output shapes on tiny inputs, gradients down to the first layer, the JSON options, the registry
// and the state-dict file. Names and outputs against the references: the torch.torchvision_oracle CTest.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <filesystem>

#include "core/error.h"
#include "core/test_options.h"
#include "core/test_util.h"
#include "training/nets/msrresnet.h"
#include "training/nets/patchgan.h"
#include "training/nets/pix2pixhd.h"
#include "training/nets/resnet.h"
#include "training/nets/unet.h"
#include "training/nets/zoo.h"

namespace bareskin::nets {
namespace {

using J = nlohmann::json;

int64_t count_of(const std::string& model, const J& options = J::object()) {
  return parameter_count(*find_model(model).make(options));
}

// The gradient of a scalar of the output reaches the first convolution's weight (nonzero, finite).
void expect_gradient_at(torch::nn::Module& net, const std::string& first, const torch::Tensor& output) {
  output.square().mean().backward();
  const torch::Tensor g = net.named_parameters().find(first)->grad();
  ASSERT_TRUE(g.defined()) << first;
  EXPECT_TRUE(torch::isfinite(g).all().item<bool>()) << first;
  EXPECT_GT(g.abs().sum().item<double>(), 0.0) << first;
}

// ---- parameter counts at the paper's sizes

TEST(NetsCount, ResNetsMatchTorchvision) {
  EXPECT_EQ(count_of("resnet18"), 11689512);                   // torchvision.models.resnet18()
  EXPECT_EQ(count_of("resnet50"), 25557032);                   // torchvision.models.resnet50()
  EXPECT_EQ(count_of("resnet18", {{"depth", 34}}), 21797672);  // torchvision.models.resnet34()
}

TEST(NetsCount, Pix2PixNets) {
  EXPECT_EQ(count_of("unet256"), 54413955);  // unet_256, batch norm, 3 → 3
  // 6·64·16+64 + 64·128·16+2·128 + 128·256·16+2·256 + 256·512·16+2·512 + 512·16+1
  EXPECT_EQ(count_of("patchgan"), 2768705);
}

TEST(NetsCount, Pix2PixHDNets) {
  // Global: 9,472 (7×7) + 6,268,800 (4 downsamplings) + 9·18,876,416 (residual blocks at 1024 channels)
  // + 6,267,840 (4 transposed) + 9,411 (7×7 head); instance norm has no parameters. This is the figure the issue gives.
  EXPECT_EQ(count_of("pix2pixhd_global"), 182443267);
  // Local (ngf 32, the reference's 2K set-up): the global at ngf 64 without its head (182,433,856) + front end
  // 4,736 + 18,496, 3 residual blocks at 64 channels 221,568, transposed 18,464, head 4,707.
  EXPECT_EQ(count_of("pix2pixhd_local"), 182701827);
  // num_D 2 × (6,208 + 131,200 + 524,544 + 2,097,664 + 8,193): convolutions with biases, instance norm.
  EXPECT_EQ(count_of("pix2pixhd_multiscale_d"), 5535618);
}

TEST(NetsCount, SuperResolutionNets) {
  // 1,792 + 16·73,856 + 2·147,712 + 36,928 + 1,731
  EXPECT_EQ(count_of("msrresnet"), 1517571);
  // conv0_0 1,792; convolutions without bias 13,672,448; batch norms 5,760; linear1 8192·100+100; linear2 101.
  EXPECT_EQ(count_of("srgan_d"), 14499401);
}

// ---- one smaller size each (figures from the Python reference layouts at the same options)

// A ResNet with BasicBlocks, counted block by block from the layout: convolutions without bias, 2 per batch norm.
int64_t basic_resnet_count(int64_t in, int64_t w, const int blocks[4], int64_t classes) {
  int64_t n = in * w * 49 + 2 * w, c = w;
  for (int i = 0; i < 4; ++i) {
    const int64_t p = w << i;
    for (int b = 0; b < blocks[i]; ++b) {
      n += 9 * c * p + 2 * p + 9 * p * p + 2 * p;
      if (c != p) n += c * p + 2 * p;  // downsample.0/.1
      c = p;
    }
  }
  return n + (classes ? c * classes + classes : 0);
}

TEST(NetsCount, SmallerSizes) {
  const int r18[4] = {2, 2, 2, 2};
  EXPECT_EQ(count_of("resnet18", {{"width", 16}, {"num_classes", 10}, {"in_channels", 1}}),
            basic_resnet_count(1, 16, r18, 10));
  EXPECT_EQ(count_of("resnet18"), basic_resnet_count(3, 64, r18, 1000));  // the formula against torchvision's figure
  EXPECT_EQ(count_of("unet256", {{"ngf", 16}}), 3404451);
  EXPECT_EQ(count_of("unet256", {{"ngf", 16}, {"num_downs", 6}, {"norm", "instance"}}), 1829987);
  EXPECT_EQ(count_of("patchgan", {{"ndf", 16}, {"norm", "instance"}}), 175857);
  EXPECT_EQ(count_of("pix2pixhd_global", {{"ngf", 16}}), 11410243);
  EXPECT_EQ(count_of("pix2pixhd_local", {{"ngf", 8}}), 11426499);
  EXPECT_EQ(count_of("pix2pixhd_multiscale_d", {{"ndf", 16}, {"num_D", 3}}), 527571);
  EXPECT_EQ(count_of("msrresnet", {{"num_feat", 16}, {"num_block", 4}}), 40323);
  EXPECT_EQ(count_of("srgan_d", {{"input_size", 256}}), 21055049);
  EXPECT_EQ(count_of("srgan_d", {{"num_feat", 16}}), 1061417);
}

TEST(NetsCount, ResizeConvReplacesEachTransposedConvolution) {
  // A 4×4 transposed convolution (in·out·16) becomes a 3×3 convolution (in·out·9); biases stay where they were.
  const int64_t transpose = count_of("unet256", {{"ngf", 16}});
  const int64_t resize = count_of("unet256", {{"ngf", 16}, {"upsample", "resize_conv"}});
  // Up-convolutions of unet ngf 16, 8 levels: (2·16 → 3) + (2·32 → 16) + (2·64 → 32) + (2·128 → 64) + 3·(2·128 → 128)
  // + (128 → 128).
  const int64_t inout = 32 * 3 + 64 * 16 + 128 * 32 + 256 * 64 + 3 * 256 * 128 + 128 * 128;
  EXPECT_EQ(transpose - resize, inout * (16 - 9));
}

// ---- initialisations as the references (standard deviations over >= 4,096 weights, 10% tolerance)

double stddev(const torch::nn::Module& net, const std::string& name) {
  return net.named_parameters().find(name)->std().item<double>();
}

TEST(NetsInit, AsTheReferences) {
  torch::manual_seed(10);
  ResNet resnet(ResNetOptions{18, 16, 10, 3});
  // torchvision: He normal with fan out = 32·3·3 for layer2's 3×3 convolutions.
  EXPECT_NEAR(stddev(*resnet, "layer2.0.conv2.weight"), std::sqrt(2.0 / (32 * 9)), 0.1 * std::sqrt(2.0 / (32 * 9)));
  EXPECT_TRUE(torch::equal(resnet->named_parameters().find("bn1.weight")->detach(), torch::ones({16})));
  UNet unet(UNetOptions{3, 3, 16, 5});
  EXPECT_NEAR(stddev(*unet, "model.model.1.model.1.weight"), 0.02, 0.002);  // pix2pix: N(0, 0.02)
  EXPECT_NEAR(unet->named_parameters().find("model.model.1.model.2.weight")->mean().item<double>(), 1.0, 0.02);
  EXPECT_EQ(unet->named_parameters().find("model.model.3.bias")->abs().sum().item<double>(), 0.0);
  MSRResNet sr(MSRResNetOptions{3, 3, 32, 1, 4});
  // BasicSR: He normal (fan in 32·9) × 0.1.
  EXPECT_NEAR(stddev(*sr, "body.0.conv1.weight"), 0.1 * std::sqrt(2.0 / (32 * 9)), 0.01 * std::sqrt(2.0 / (32 * 9)));
}

// ---- shapes and gradients on tiny inputs

TEST(NetsForward, ResNetFeaturesAndHead) {
  torch::manual_seed(1);
  ResNet net(ResNetOptions{50, 8, 7, 3});
  const torch::Tensor x = torch::randn({2, 3, 64, 64});
  EXPECT_EQ(net->features(x).sizes(), (std::vector<int64_t>{2, 8 * 8 * 4}));
  EXPECT_EQ(net->feature_channels(), 256);
  const torch::Tensor y = net->forward(x);
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{2, 7}));
  expect_gradient_at(*net, "conv1.weight", y);
  ResNet headless(ResNetOptions{18, 8, 0, 3});
  EXPECT_EQ(headless->forward(x).sizes(), (std::vector<int64_t>{2, 64}));
  EXPECT_EQ(headless->named_parameters().find("fc.weight"), nullptr);
}

TEST(NetsForward, UNetShapesRangeAndGradient) {
  torch::manual_seed(2);
  for (const std::string up : {"transpose", "resize_conv"}) {
    SCOPED_TRACE(up);
    UNetOptions o;
    o.ngf = 8;
    o.num_downs = 6;
    o.out_channels = 4;
    o.upsample = up;
    UNet net(o);
    const torch::Tensor y = net->forward(torch::randn({2, 3, 64, 64}));
    EXPECT_EQ(y.sizes(), (std::vector<int64_t>{2, 4, 64, 64}));
    EXPECT_LE(y.abs().max().item<double>(), 1.0);  // Tanh
    expect_gradient_at(*net, "model.model.0.weight", y);
  }
  UNet net(UNetOptions{3, 3, 8, 6});
  EXPECT_THROW(net->forward(torch::randn({1, 3, 48, 64})), InvalidInput);  // 48 is not a multiple of 64
  // max_mult: the widths double level by level up to ngf × max_mult (8: 64 channels at most here; 32: 256), and the
  // default is not written into a configuration. The widest weight dimension: at 8, 128 (an up-convolution's input,
  // 64 doubled by the skip connection); at 32, 256 (the innermost width; the level above it has 128, doubled).
  auto widest = [](const UNet& u) {
    int64_t w = 0;
    for (const auto& p : u->parameters()) w = std::max(w, p.size(0));
    return w;
  };
  EXPECT_EQ(widest(net), 128);
  UNetOptions wide{3, 3, 8, 6};
  wide.max_mult = 32;
  UNet w(wide);
  EXPECT_EQ(widest(w), 256);
  EXPECT_EQ(w->forward(torch::randn({1, 3, 64, 64})).sizes(), (std::vector<int64_t>{1, 3, 64, 64}));
  EXPECT_FALSE(nlohmann::json(UNetOptions{}).contains("max_mult"));
  EXPECT_EQ(nlohmann::json(wide).get<UNetOptions>().max_mult, 32);
  EXPECT_THROW(nlohmann::json({{"max_mult", 0}}).get<UNetOptions>(), InvalidInput);
  // tanh false: the same weights without the final tanh (the module and the inference path), written only when set.
  UNetOptions linear{3, 3, 8, 6};
  linear.tanh = false;
  UNet lin(linear);
  torch::manual_seed(5);
  for (auto& p : lin->parameters()) p.data().normal_(0, 0.5);  // outputs well beyond ±1
  UNet tanh_net(UNetOptions{3, 3, 8, 6});
  {
    torch::NoGradGuard no_grad;
    auto params = tanh_net->named_parameters();
    for (const auto& p : lin->named_parameters()) params[p.key()].copy_(p.value());
    auto buffers = tanh_net->named_buffers();
    for (const auto& b : lin->named_buffers()) buffers[b.key()].copy_(b.value());
  }
  lin->eval();
  tanh_net->eval();
  const torch::Tensor x = torch::randn({1, 3, 64, 64});
  const torch::Tensor y = lin->forward(x);
  EXPECT_GT(y.abs().max().item<double>(), 1.5);
  EXPECT_TRUE(torch::allclose(torch::tanh(y), tanh_net->forward(x), 1e-5, 1e-5));
  const torch::Tensor fused = UNetInference(*lin).forward(x.clone());
  EXPECT_LT(((fused - y).abs().max() / y.abs().max()).item<double>(), 1e-5) << y.abs().max().item<double>();
  EXPECT_FALSE(nlohmann::json(UNetOptions{}).contains("tanh"));
  EXPECT_FALSE(nlohmann::json(linear).get<UNetOptions>().tanh);
}

TEST(NetsForward, UNetDropoutOnlyWhenTraining) {
  torch::manual_seed(3);
  UNet net(UNetOptions{3, 3, 8, 6});
  const torch::Tensor x = torch::randn({2, 3, 64, 64});
  net->eval();
  EXPECT_TRUE(torch::equal(net->forward(x), net->forward(x)));
  net->train();
  EXPECT_FALSE(torch::equal(net->forward(x), net->forward(x)));
}

TEST(NetsForward, PatchGANLogitMap) {
  torch::manual_seed(4);
  PatchGAN net(PatchGANOptions{6, 8, 3, "batch"});
  const torch::Tensor y = net->forward(torch::randn({2, 6, 64, 64}));
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{2, 1, 6, 6}));  // 64 → 32 → 16 → 8 → 7 → 6
  expect_gradient_at(*net, "model.0.weight", y);
}

TEST(NetsForward, GlobalAndLocalGenerators) {
  torch::manual_seed(5);
  GlobalGeneratorOptions g;
  g.ngf = 8;
  g.n_downsampling = 3;
  g.n_blocks = 2;
  GlobalGenerator global(g);
  torch::Tensor y = global->forward(torch::randn({2, 3, 32, 32}));
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{2, 3, 32, 32}));
  expect_gradient_at(*global, "model.1.weight", y);
  LocalEnhancerOptions l;
  l.ngf = 4;
  l.n_downsample_global = 2;
  l.n_blocks_global = 1;
  l.n_blocks_local = 1;
  l.out_channels = 2;
  LocalEnhancer local(l);
  y = local->forward(torch::randn({2, 3, 32, 32}));
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{2, 2, 32, 32}));
  expect_gradient_at(*local, "model1_1.1.weight", y);
  local->zero_grad();
  y = local->forward(torch::randn({2, 3, 32, 32}));
  expect_gradient_at(*local, "model.1.weight", y);  // the global part at half resolution
  EXPECT_THROW(local->forward(torch::randn({1, 3, 20, 32})), InvalidInput);
}

TEST(NetsForward, MultiscaleDiscriminatorFeatures) {
  torch::manual_seed(6);
  MultiscaleDiscriminatorOptions o;
  o.ndf = 8;
  o.num_D = 3;
  MultiscaleDiscriminator net(o);
  const auto out = net->forward(torch::randn({2, 6, 64, 64}));
  ASSERT_EQ(out.size(), 3u);
  // Padding 2: 64 → 33 → 17 → 9 → 10 → 11 at scale 0; the input halves (AvgPool 3/2/1) between scales.
  const int64_t sides[3][5] = {{33, 17, 9, 10, 11}, {17, 9, 5, 6, 7}, {9, 5, 3, 4, 5}};
  const int64_t channels[5] = {8, 16, 32, 64, 1};
  for (int s = 0; s < 3; ++s) {
    ASSERT_EQ(out[s].size(), 5u);
    for (int j = 0; j < 5; ++j)
      EXPECT_EQ(out[s][j].sizes(), (std::vector<int64_t>{2, channels[j], sides[s][j], sides[s][j]})) << s << " " << j;
  }
  // Scale 0 (full resolution) is the reference's last discriminator.
  torch::Tensor sum = out[0].back().sum();
  sum.backward();
  EXPECT_GT(net->named_parameters().find("scale2_layer0.0.weight")->grad().abs().sum().item<double>(), 0.0);
  EXPECT_FALSE(net->named_parameters().find("scale0_layer0.0.weight")->grad().defined());
  o.get_interm_feat = false;
  MultiscaleDiscriminator plain(o);
  const auto logits = plain->forward(torch::randn({2, 6, 64, 64}));
  ASSERT_EQ(logits.size(), 3u);
  EXPECT_EQ(logits[1].size(), 1u);
  EXPECT_EQ(logits[1][0].sizes(), (std::vector<int64_t>{2, 1, 7, 7}));
  EXPECT_NE(plain->named_parameters().find("layer2.11.weight"), nullptr);  // conv, norm, leaky ×3 after conv, leaky
}

TEST(NetsForward, DownsampleExcludesPadding) {
  // count_include_pad = false: a constant image stays constant at the border.
  const torch::Tensor y = downsample_avg(torch::full({1, 1, 5, 5}, 3.0));
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{1, 1, 3, 3}));
  EXPECT_TRUE(torch::allclose(y, torch::full({1, 1, 3, 3}, 3.0)));
}

TEST(NetsForward, SuperResolution) {
  torch::manual_seed(7);
  MSRResNet sr(MSRResNetOptions{3, 3, 8, 2, 4});
  const torch::Tensor x = torch::rand({2, 3, 8, 8});
  const torch::Tensor y = sr->forward(x);
  EXPECT_EQ(y.sizes(), (std::vector<int64_t>{2, 3, 32, 32}));
  expect_gradient_at(*sr, "conv_first.weight", y);
  // The network learns a residual over bilinear ×4: at BasicSR's ×0.1 initialisation it is small.
  namespace F = torch::nn::functional;
  const torch::Tensor base = F::interpolate(
      x,
      F::InterpolateFuncOptions().scale_factor(std::vector<double>{4, 4}).mode(torch::kBilinear).align_corners(false));
  EXPECT_LT((y - base).abs().max().item<double>(), 0.1);
  for (int upscale : {2, 3}) {
    MSRResNet other(MSRResNetOptions{1, 1, 8, 1, upscale});
    EXPECT_EQ(other->forward(torch::rand({1, 1, 5, 5})).sizes(),
              (std::vector<int64_t>{1, 1, 5 * upscale, 5 * upscale}));
    EXPECT_EQ(other->named_parameters().find("upconv2.weight"), nullptr);
  }
  VGGStyleDiscriminator d(VGGStyleDiscriminatorOptions{3, 4, 128});
  const torch::Tensor logits = d->forward(torch::randn({2, 3, 128, 128}));
  EXPECT_EQ(logits.sizes(), (std::vector<int64_t>{2, 1}));
  expect_gradient_at(*d, "conv0_0.weight", logits);
  EXPECT_THROW(d->forward(torch::randn({2, 3, 96, 96})), InvalidInput);
}

// ---- the registry and options

TEST(NetsZoo, EveryEntryBuildsFromItsDefaultsAndRoundTrips) {
  const std::vector<std::string> names = {
      "resnet18",  "resnet50", "unet256", "patchgan", "pix2pixhd_global", "pix2pixhd_local", "pix2pixhd_multiscale_d",
      "msrresnet", "srgan_d"};
  ASSERT_EQ(model_zoo().size(), names.size());
  for (size_t i = 0; i < names.size(); ++i) {
    const ModelEntry& e = model_zoo()[i];
    EXPECT_EQ(e.name, names[i]);
    EXPECT_FALSE(e.summary.empty());
    EXPECT_EQ(e.summary.find('\n'), std::string::npos);
    EXPECT_TRUE(e.defaults.is_object()) << e.name;
    EXPECT_EQ(&find_model(e.name), &e);
  }
  // Options through JSON and back: to_json(from_json(x)) == x for a non-default set.
  UNetOptions u;
  J j = {{"ngf", 16}, {"norm", "instance"}, {"upsample", "resize_conv"}, {"dropout", false}};
  from_json(j, u);
  EXPECT_EQ(u.ngf, 16);
  EXPECT_EQ(u.num_downs, 8);
  EXPECT_EQ(J(u)["upsample"], "resize_conv");
  EXPECT_EQ(J(u).get<UNetOptions>().norm, "instance");
  EXPECT_EQ(find_model("resnet50").defaults["depth"], 50);
  EXPECT_EQ(find_model("pix2pixhd_multiscale_d").defaults["num_D"], 2);
}

// Every options struct of the zoo through core/json_options.h: non-default values round-trip with their types, an
// unknown key or a wrong type is refused naming the key.
TEST(NetsZoo, OptionsRoundTripAndRefuseUnknownKeys) {
  testing::expect_options_json<ResNetOptions>({{"depth", 34}, {"width", 16}, {"num_classes", 0}, {"in_channels", 4}});
  testing::expect_options_json<UNetOptions>({{"in_channels", 4},
                                             {"out_channels", 2},
                                             {"ngf", 16},
                                             {"num_downs", 6},
                                             {"norm", "instance"},
                                             {"dropout", false},
                                             {"upsample", "resize_conv"}});
  testing::expect_options_json<PatchGANOptions>({{"in_channels", 3}, {"ndf", 8}, {"n_layers", 2}, {"norm", "none"}});
  testing::expect_options_json<GlobalGeneratorOptions>(
      {{"in_channels", 13}, {"out_channels", 8}, {"ngf", 8}, {"n_downsampling", 2}, {"n_blocks", 1}, {"norm", "batch"}});
  testing::expect_options_json<LocalEnhancerOptions>({{"in_channels", 13},
                                                      {"out_channels", 8},
                                                      {"ngf", 8},
                                                      {"n_downsample_global", 2},
                                                      {"n_blocks_global", 1},
                                                      {"n_local_enhancers", 2},
                                                      {"n_blocks_local", 1},
                                                      {"norm", "batch"}});
  testing::expect_options_json<MultiscaleDiscriminatorOptions>({{"in_channels", 21},
                                                                {"ndf", 8},
                                                                {"n_layers", 2},
                                                                {"norm", "batch"},
                                                                {"num_D", 3},
                                                                {"get_interm_feat", false},
                                                                {"use_sigmoid", true}});
  testing::expect_options_json<MSRResNetOptions>(
      {{"num_in_ch", 1}, {"num_out_ch", 1}, {"num_feat", 8}, {"num_block", 2}, {"upscale", 2}, {"base", "bicubic"}});
  testing::expect_options_json<VGGStyleDiscriminatorOptions>({{"num_in_ch", 1}, {"num_feat", 8}, {"input_size", 256}});
  // A bad value is refused by from_json as well as by the constructor (check()); an integer option refuses 8.5.
  EXPECT_THROW(J({{"depth", 20}}).get<ResNetOptions>(), InvalidInput);
  EXPECT_THROW(J({{"ngf", 8.5}}).get<UNetOptions>(), InvalidInput);
  UNetOptions bad;
  bad.num_downs = 4;
  EXPECT_THROW(bad.check(), InvalidInput);
}

TEST(NetsZoo, BadNamesAndOptionsAreTheUsersError) {
  try {
    find_model("unet512");
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("resnet18, resnet50"), std::string::npos) << e.what();
  }
  try {
    find_model("resnet18").make({{"widht", 32}});
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("unknown key 'widht'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(find_model("resnet18").make({{"depth", "18"}}), InvalidInput);  // wrong type
  EXPECT_THROW(find_model("resnet18").make({{"depth", 20}}), InvalidInput);
  EXPECT_THROW(find_model("unet256").make({{"num_downs", 4}}), InvalidInput);
  EXPECT_THROW(find_model("unet256").make({{"upsample", "nearest"}}), InvalidInput);
  EXPECT_THROW(find_model("patchgan").make({{"norm", "group"}}), InvalidInput);
  EXPECT_THROW(find_model("pix2pixhd_global").make({{"norm", "none"}}), InvalidInput);
  EXPECT_THROW(find_model("msrresnet").make({{"upscale", 8}}), InvalidInput);
  EXPECT_THROW(find_model("msrresnet").make({{"num_out_ch", 1}}), InvalidInput);
  EXPECT_THROW(find_model("srgan_d").make({{"input_size", 64}}), InvalidInput);
  EXPECT_THROW(find_model("patchgan").make(J::array()), InvalidInput);
}

TEST(NetsZoo, ForwardOutputOfAnyEntry) {
  torch::manual_seed(9);
  const auto d = find_model("pix2pixhd_multiscale_d").make({{"ndf", 4}});
  // Two scales, five layer outputs each (2·(4·33² + 8·17² + 16·9² + 32·10² + 11²) + same at 32² input).
  const int64_t s0 = 4 * 33 * 33 + 8 * 17 * 17 + 16 * 9 * 9 + 32 * 10 * 10 + 11 * 11;
  const int64_t s1 = 4 * 17 * 17 + 8 * 9 * 9 + 16 * 5 * 5 + 32 * 6 * 6 + 7 * 7;
  EXPECT_EQ(forward_output(*d, torch::randn({1, 6, 64, 64})).numel(), s0 + s1);
  const auto sr = find_model("msrresnet").make({{"num_feat", 4}, {"num_block", 1}});
  EXPECT_EQ(forward_output(*sr, torch::randn({1, 3, 4, 4})).sizes(), (std::vector<int64_t>{1, 3, 16, 16}));
  torch::nn::Linear stranger(2, 2);
  EXPECT_THROW(forward_output(*stranger, torch::randn({1, 2})), InternalError);
}

// ---- the state-dict file

TEST(NetsExport, ReferenceNamesAndRoundTrip) {
  const std::string dir = testing::temp_dir();
  torch::manual_seed(8);
  const auto net = find_model("unet256").make({{"ngf", 4}, {"num_downs", 5}});
  const std::string path = dir + "/unet.safetensors";
  export_state_dict(*net, path, {{"model", "unet256"}});
  const auto dict = state_dict(*net);
  // pix2pix's recursive names: outermost block → model.model.1 (next block) → its .model.3 (next) ...; the innermost
  // (num_downs 5: the fifth) ends with its up-convolution at index 3 and norm at 4, buffers included.
  for (const char* name : {"model.model.0.weight", "model.model.3.bias", "model.model.1.model.1.weight",
                           "model.model.1.model.2.running_mean", "model.model.1.model.3.model.3.model.3.model.3.weight",
                           "model.model.1.model.3.model.3.model.3.model.4.num_batches_tracked"})
    EXPECT_TRUE(dict.count(name)) << name;
  EXPECT_EQ(dict.size(), net->named_parameters().size() + net->named_buffers().size());
  const auto other = find_model("unet256").make({{"ngf", 4}, {"num_downs", 5}});
  import_state_dict(*other, path);
  for (const auto& [name, t] : state_dict(*other)) EXPECT_TRUE(torch::equal(t, dict.at(name))) << name;
  const auto wider = find_model("unet256").make({{"ngf", 8}, {"num_downs", 5}});
  EXPECT_THROW(import_state_dict(*wider, path), InvalidInput);
  const auto deeper = find_model("unet256").make({{"ngf", 4}, {"num_downs", 6}});
  EXPECT_THROW(import_state_dict(*deeper, path), InvalidInput);
  EXPECT_THROW(import_state_dict(*other, dir + "/missing.safetensors"), IoError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace bareskin::nets
