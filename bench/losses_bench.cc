// Speed of the perceptual losses as training uses them: LPIPS forward + backward (to the first input) at 256², batch
// 4, per trunk; the identity loss likewise; SSIM for scale. Medians over repeats after one warm-up; CUDA timings
// synchronise before reading the clock.
//   losses_bench [REPEATS] [cpu|cuda]     (face-api's weights from $BARESKIN_ASSETS/face_api, else assets/face_api)
#include <malloc.h>
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include "detect/face_api.h"
#include "training/identity.h"
#include "training/lpips.h"
#include "bench/bench_util.h"
#include "training/ssim.h"

// One namespace per program: bench/torch_bench.cc runs this main under the name `losses_bench` (one binary, one unity
// translation unit for every Torch bench).
namespace bareskin_bench_losses {

using namespace bareskin;

int main(int argc, char** argv) {
  mallopt(M_MMAP_MAX, 0);  // as the CLI: page faults are expensive on our VMs
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  const int repeats = argc > 1 ? std::atoi(argv[1]) : 5;
  const bool cuda = argc > 2 && std::string(argv[2]) == "cuda";
  const torch::Device device = cuda ? torch::kCUDA : torch::kCPU;
  torch::set_num_threads(int(std::thread::hardware_concurrency()));  // LibTorch counts physical cores only
  std::printf("device %s, threads %d, batch 4 × 3 × 256², forward + backward, median of %d\n", cuda ? "cuda" : "cpu",
              torch::get_num_threads(), repeats);
  torch::manual_seed(1);
  const torch::Tensor a = torch::rand({4, 3, 256, 256}, device), b = torch::rand({4, 3, 256, 256}, device);
  auto timed = [&](const std::function<torch::Tensor(const torch::Tensor&)>& loss) {
    return bench::median_ms(
        [&] {
          const torch::Tensor x = a.clone().requires_grad_(true);
          loss(x).backward();
        },
        repeats, cuda);
  };
  for (const std::string trunk : {"vgg16-random", "facenet"}) {
    losses::Lpips lpips(trunk, detect::default_face_api_folder());
    lpips->to(device);
    const double ms = timed([&](const torch::Tensor& x) { return lpips->forward(x, b).mean(); });
    std::printf("LPIPS trunk %-13s %8.1f ms\n", lpips->trunk_name().c_str(), ms);
  }
  detect::FaceRecognitionNet net(detect::default_face_api_folder());
  net->to(device);
  std::printf("identity (facenet)     %8.1f ms\n",
              timed([&](const torch::Tensor& x) { return losses::identity_loss(net, x, b); }));
  std::printf("SSIM                   %8.1f ms\n",
              timed([&](const torch::Tensor& x) { return 1 - losses::ssim(x, b).mean(); }));
  return 0;
}

}  // namespace bareskin_bench_losses
