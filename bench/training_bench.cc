// What training costs per step, and whether data keeps up:
//   1. the shard loader's throughput (samples/s decoded at 256²: three PNGs + JSON, with and without augmentation,
//      1 and 2 decode threads) against the step time — at batch 4 a step must not wait on data;
//   2. a "BareSkinNet-like step": U-Net G + PatchGAN D + ResNet-18 E + frozen ResNet-50 F + LPIPS (vgg16-random trunk)
//      + the differentiable render of a 3DMM-sized mesh under SH light, batch 4, 256²: D's update, then G and E
//      jointly (L1 x100, GAN, LPIPS x40, coefficients vs F, unlit render vs G's output, lit render vs the before
//      image). At the paper's sizes and at the demo's; medians after a warm-up; CUDA events on a GPU.
//   training_bench [--steps N] [--sizes demo,paper] [--device cpu|cuda] [--skip-loader]
#include <fmt/format.h>
#include <malloc.h>
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <thread>

#include "core/png.h"
#include "core/shards.h"
#include "training/data.h"
#include "bench/bench_util.h"
#include "render/torch/ops.h"
#include "training/lpips.h"
#include "training/losses.h"
#include "training/nets/zoo.h"

// One namespace per program: bench/torch_bench.cc runs this main under the name `training_bench` (one binary, one unity
// translation unit for every Torch bench).
namespace bareskin_bench_training {

using namespace bareskin;
namespace fs = std::filesystem;

namespace {

// 64 samples like texgen faces writes: makeup, before (RGB 256²), skin mask (grey), JSON with 68 landmarks.
std::string write_dataset() {
  const std::string dir = (fs::temp_directory_path() / ("bareskin_loader_bench_" + std::to_string(::getpid()))).string();
  fs::create_directories(dir);
  shards::ShardWriter writer(dir, "bench", 16);
  torch::manual_seed(0);
  for (int i = 0; i < 64; ++i) {
    // Smooth colour with fine noise: compresses like a face photo, not like flat colour or white noise.
    auto smooth = torch::nn::functional::interpolate(torch::rand({1, 3, 8, 8}),
        torch::nn::functional::InterpolateFuncOptions().size(std::vector<int64_t>{256, 256}).mode(torch::kBicubic).align_corners(false));
    auto to_png = [](const torch::Tensor& chw) {
      auto hwc = chw.clamp(0, 1).permute({1, 2, 0}).contiguous();
      Image image(256, 256, int(hwc.size(2)));
      std::memcpy(image.pixels.data(), hwc.data_ptr<float>(), image.pixels.size() * sizeof(float));
      return encode_png(image);
    };
    auto makeup = smooth[0] + 0.03 * torch::randn({3, 256, 256});
    nlohmann::json meta = {{"landmarks", nlohmann::json::array()}};
    for (int k = 0; k < 68; ++k) meta["landmarks"].push_back({60 + k * 2, 80 + (k % 17) * 6});
    writer.write({fmt::format("{:06d}", i),
                  {{"makeup.png", to_png(makeup)}, {"before.png", to_png(makeup * 0.9)},
                   {"skin.png", to_png((smooth[0].slice(0, 0, 1) > 0.5).to(torch::kFloat))}, {"json", meta.dump()}}});
  }
  shards::write_manifest(dir, {writer.finish(), {}});
  return dir;
}

void loader_throughput() {
  const std::string dir = write_dataset();
  std::printf("shard loader: 64 samples of makeup + before (RGB 256² PNG), skin mask, JSON; batch 4\n");
  std::printf("%-8s %-8s %12s %14s\n", "threads", "augment", "samples/s", "ms per batch");
  for (bool augment : {false, true})
    for (int threads : {1, 2}) {
      data::LoaderOptions o;
      o.dataset = dir;
      o.batch_size = 4;
      o.decode_threads = threads;
      o.shuffle_buffer = 16;
      o.augment.enabled = augment;
      data::ShardLoader loader(o);
      loader.next();  // warm-up
      const int batches = 48;
      const double ms = bench::time_ms([&] { for (int b = 0; b < batches; ++b) loader.next(); }, false) / batches;
      std::printf("%-8d %-8s %12.1f %14.2f\n", threads, augment ? "yes" : "no", 4000.0 / ms, ms);
    }
  fs::remove_all(dir);
}

// A 3DMM-sized mesh: a grid of n x n vertices bent into a half cylinder (a face-like surface facing the camera).
std::pair<torch::Tensor, torch::Tensor> grid_mesh(int64_t n) {
  auto u = torch::linspace(-1, 1, n), v = torch::linspace(-1, 1, n);
  auto grids = torch::meshgrid({v, u}, "ij");
  auto x = grids[1] * 80, y = -grids[0] * 100, z = (1 - grids[1].pow(2)) * 60;
  auto verts = torch::stack({x, y, z}, 2).reshape({n * n, 3});
  std::vector<int64_t> tri;
  for (int64_t r = 0; r + 1 < n; ++r)
    for (int64_t c = 0; c + 1 < n; ++c) {
      const int64_t a = r * n + c;
      tri.insert(tri.end(), {a, a + n, a + 1, a + 1, a + n, a + n + 1});
    }
  return {verts, torch::tensor(tri).view({-1, 3})};
}

struct Size {
  const char* name;
  nlohmann::json g, d, e, f;
  int64_t grid;
};

void bareskinnet_step(const Size& size, torch::Device device, int steps) {
  torch::manual_seed(1);
  auto make = [&](const char* model, const nlohmann::json& options) {
    auto net = nets::find_model(model).make(options);
    net->to(device);
    return net;
  };
  auto G = make("unet256", size.g), D = make("patchgan", size.d), E = make("resnet18", size.e),
       F = make("resnet50", size.f);
  F->eval();
  for (auto& p : F->parameters()) p.requires_grad_(false);
  losses::Lpips lpips("vgg16-random");
  lpips->to(device);
  auto [verts, tri] = grid_mesh(size.grid);
  verts = verts.to(device);
  tri = tri.to(device);
  const int64_t B = 4, V = verts.size(0), K = 80;
  auto basis = (torch::randn({K, V * 3}) * 0.5).to(device);
  auto albedo = (torch::rand({1, V, 3}) * 0.5 + 0.3).to(device);
  torch::optim::Adam opt_d(D->parameters(), torch::optim::AdamOptions(2e-5).betas({0.5, 0.999}));
  std::vector<torch::Tensor> ge = G->parameters();
  for (auto& p : E->parameters()) ge.push_back(p);
  torch::optim::Adam opt_ge(ge, torch::optim::AdamOptions(2e-5).betas({0.5, 0.999}));
  auto makeup = torch::rand({B, 3, 256, 256}).to(device), before = torch::rand({B, 3, 256, 256}).to(device);

  auto render = [&](const torch::Tensor& coeff, const torch::Tensor& gamma, bool lit) {
    auto world = verts.unsqueeze(0) + coeff.narrow(1, 0, K).matmul(basis).view({B, V, 3});
    auto depth = 1000 - world.select(2, 2);
    const double f = 1015.0 * 256 / 224;
    auto pos = torch::stack({128 + f * world.select(2, 0) / depth, 128 - f * world.select(2, 1) / depth, depth}, 2);
    auto raster = render_torch::rasterize(pos.detach(), tri, 256, 256, true);
    auto attr = render_torch::interpolate(torch::cat({albedo.expand({B, V, 3}), bench::vertex_normals(world, tri)}, 2), pos, tri, raster);
    auto image = lit ? render_torch::sh_shade(attr.narrow(3, 0, 3), attr.narrow(3, 3, 3), gamma) : attr.narrow(3, 0, 3);
    return std::make_pair(image.permute({0, 3, 1, 2}), (raster.triangle >= 0).unsqueeze(1).to(image.dtype()));
  };
  auto step = [&] {
    auto out = (nets::forward_output(*G, makeup) + 1) / 2;
    // D: real pairs vs G's output (detached).
    opt_d.zero_grad();
    auto d_loss = losses::gan_loss(nets::forward_output(*D, torch::cat({makeup, before}, 1)), true, losses::GanKind::Vanilla, true) +
                  losses::gan_loss(nets::forward_output(*D, torch::cat({makeup, out.detach()}, 1)), false, losses::GanKind::Vanilla, true);
    d_loss.backward();
    opt_d.step();
    // G and E: L_DD and L_FR.
    opt_ge.zero_grad();
    torch::Tensor f_coeff;
    {
      torch::NoGradGuard no_grad;
      f_coeff = nets::forward_output(*F, makeup).narrow(1, 0, K + 27);
    }
    auto e_coeff = nets::forward_output(*E, makeup).narrow(1, 0, K) * 0.01;
    auto gamma = f_coeff.narrow(1, K, 27) * 0.01 + 0.3;
    auto [unlit, mask] = render(e_coeff, gamma, false);
    auto [lit, mask_lit] = render(e_coeff, gamma, true);
    auto loss = 100 * losses::l1(out, before) +
                losses::gan_loss(nets::forward_output(*D, torch::cat({makeup, out}, 1)), true, losses::GanKind::Vanilla, false) +
                40 * lpips->forward(out, before).mean() + 0.1 * (e_coeff - f_coeff.narrow(1, 0, K) * 0.01).pow(2).mean() +
                100 * losses::masked_l1(unlit, out, mask) + 100 * losses::masked_l1(lit, before, mask_lit);
    loss.backward();
    opt_ge.step();
    if (device.is_cuda()) torch::cuda::synchronize();
  };
  const double step_ms = bench::median_ms(step, steps, device.is_cuda());
  int64_t params = 0;
  for (auto* net : {&G, &D, &E, &F})
    for (const auto& p : (*net)->parameters()) params += p.numel();
  std::printf("%-6s %-6s %12.1f %10lld %12.1f\n", device.is_cuda() ? "cuda" : "cpu", size.name, params / 1e6,
              (long long)V, step_ms);
}

}  // namespace

int main(int argc, char** argv) {
  mallopt(M_MMAP_MAX, 0);  // page faults are expensive on our VMs (docs/training.md)
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  torch::set_num_threads(int(std::thread::hardware_concurrency()));
  int steps = 3;
  std::string sizes = "demo,paper", device_name = torch::cuda::is_available() ? "cuda" : "cpu";
  bool loader = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--steps" && i + 1 < argc) steps = std::atoi(argv[++i]);
    else if (a == "--sizes" && i + 1 < argc) sizes = argv[++i];
    else if (a == "--device" && i + 1 < argc) device_name = argv[++i];
    else if (a == "--skip-loader") loader = false;
    else {
      std::fprintf(stderr, "usage: training_bench [--steps N] [--sizes demo,paper] [--device cpu|cuda] [--skip-loader]\n");
      return 2;
    }
  }
  if (loader) loader_throughput();
  const torch::Device device(device_name == "cuda" ? torch::kCUDA : torch::kCPU);
  const Size demo{"demo", {{"ngf", 16}, {"num_downs", 8}, {"upsample", "resize_conv"}}, {{"ndf", 16}},
                  {{"width", 16}, {"num_classes", 107}}, {{"width", 16}, {"num_classes", 107}}, 128};
  const Size paper{"paper", nlohmann::json::object(), nlohmann::json::object(), {{"num_classes", 257}},
                   {{"num_classes", 257}}, 256};
  std::printf("\nBareSkinNet-like step, batch 4, 256², %d %s thread(s); LPIPS trunk vgg16-random; median of %d steps\n",
              torch::get_num_threads(), device.is_cuda() ? "CPU (+ GPU)" : "CPU", steps);
  std::printf("%-6s %-6s %12s %10s %12s\n", "device", "size", "params (M)", "vertices", "step ms");
  for (const Size* s : {&demo, &paper})
    if (sizes.find(s->name) != std::string::npos) bareskinnet_step(*s, device, steps);
  return 0;
}

}  // namespace bareskin_bench_training
