// Speed of face-api's networks in LibTorch: per-face CPU latency (preprocessing + detector at 416² + one 112²
// landmark crop, the work of 'landmarks detect' on one face) and, where CUDA is present, batch throughput of both
// networks. Timings are medians over repeats after a warm-up; CUDA timings synchronise before reading the clock.
//   detect_bench [WEIGHTS_DIR] [REPEATS]
#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <malloc.h>
#include <thread>
#include <vector>

#include "detect/face_api.h"
#include "bench/bench_util.h"

// One namespace per program: bench/torch_bench.cc runs this main under the name `detect_bench` (one binary, one unity
// translation unit for every Torch bench).
namespace bareskin_bench_detect {

using namespace bareskin::detect;
using bareskin::bench::median_ms;

int main(int argc, char** argv) {
  mallopt(M_MMAP_MAX, 0);  // as the CLI: page faults are expensive on our VMs
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  torch::set_num_threads(int(std::thread::hardware_concurrency()));  // LibTorch counts physical cores only
  const std::string folder = argc > 1 ? argv[1] : default_face_api_folder();
  const int repeats = argc > 2 ? std::atoi(argv[2]) : 30;
  FaceApi net(folder);
  torch::manual_seed(1);
  const torch::Tensor photo = torch::rand({512, 512, 3});
  const Box box{163, 75, 116, 111};
  const double mean[3] = {117.001, 114.697, 97.404};
  std::printf("threads %d\n", torch::get_num_threads());
  const double prep = median_ms([&] { FaceApi::prepare(photo, 416, false, mean); }, repeats, false);
  const torch::Tensor x = FaceApi::prepare(photo, 416, false, mean);
  const double det = median_ms([&] { net.detector_net(x); }, repeats, false);
  const double lm = median_ms([&] { net.landmarks(photo, {box}); }, repeats, false);
  for (int size : {320, 224, 160}) {
    const torch::Tensor small = FaceApi::prepare(photo, size, false, mean);
    std::printf("cpu detector %d²: %.2f ms\n", size, median_ms([&] { net.detector_net(small); }, repeats, false));
  }
  std::printf("cpu per face (512² photo): prepare %.2f ms + detector 416² %.2f ms + landmarks %.2f ms = %.2f ms\n",
              prep, det, lm, prep + det + lm);
  if (!torch::cuda::is_available()) {
    std::printf("cuda: not available\n");
    return 0;
  }
  net.to(torch::kCUDA);
  for (int batch : {1, 16, 64}) {
    const torch::Tensor scenes = torch::randn({batch, 3, 416, 416}, torch::kCUDA);
    const double ms = median_ms([&] { net.detector_net(scenes); }, repeats, true);
    std::printf("cuda detector 416², batch %3d: %.3f ms, %.0f images/s\n", batch, ms, batch * 1000 / ms);
  }
  for (int batch : {1, 64, 256, 1024}) {
    const torch::Tensor crops = torch::randn({batch, 3, 112, 112}, torch::kCUDA);
    const double ms = median_ms([&] { net.landmark_net(crops); }, repeats, true);
    std::printf("cuda landmarks 112², batch %4d: %.3f ms, %.0f faces/s\n", batch, ms, batch * 1000 / ms);
  }
  return 0;
}

}  // namespace bareskin_bench_detect
