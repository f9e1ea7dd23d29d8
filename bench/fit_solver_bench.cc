// The choice of solver for mm-fit's landmark term, by measurement: our Levenberg–Marquardt (morphable/fit.h, Eigen,
// forward-difference Jacobian) against LibTorch's Adam on the same objective — pose, α, β; Σ|π(R S_k + t) − l_k|² +
// λ(|α|² + |β|²) with the same camera — from the same start (zero pose offsets and coefficients). Prints, per solver, the
// time and iterations to reach 1 px and 0.1 px landmark RMS and where it ends.
//   fit_solver_bench MODEL.safetensors LANDMARKS.json [IMAGE_SIZE]
#include <torch/torch.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <malloc.h>
#include <thread>

#include "core/landmarks.h"
#include "morphable/fit.h"
#include "morphable/model.h"

// One namespace per program: bench/torch_bench.cc runs this main under the name `fit_solver_bench` (one binary, one unity
// translation unit for every Torch bench).
namespace bareskin_bench_fit_solver {

using namespace bareskin;

namespace {

struct Progress {
  int iterations_1px = -1, iterations_01px = -1, iterations = 0;
  double ms_1px = NAN, ms_01px = NAN, ms = 0, rms = 0;
  void add(int it, double ms_now, double rms_now) {
    if (rms_now <= 1 && iterations_1px < 0) iterations_1px = it, ms_1px = ms_now;
    if (rms_now <= 0.1 && iterations_01px < 0) iterations_01px = it, ms_01px = ms_now;
    iterations = it, ms = ms_now, rms = rms_now;
  }
  void print(const char* name) const {
    std::printf("%-34s %5d it %9.2f ms %7d it %9.2f ms %7d it %9.2f ms %9.4f px\n", name, iterations_1px, ms_1px,
                iterations_01px, ms_01px, iterations, ms, rms);
  }
};

// The rotation Rz·Ry·Rx of euler_rotation, in Torch.
torch::Tensor rotation(const torch::Tensor& a) {
  const auto c = torch::cos(a), s = torch::sin(a);
  const auto one = torch::ones({}, a.options()), zero = torch::zeros({}, a.options());
  const auto Rx = torch::stack({one, zero, zero, zero, c[0], -s[0], zero, s[0], c[0]}).reshape({3, 3});
  const auto Ry = torch::stack({c[1], zero, s[1], zero, one, zero, -s[1], zero, c[1]}).reshape({3, 3});
  const auto Rz = torch::stack({c[2], -s[2], zero, s[2], c[2], zero, zero, zero, one}).reshape({3, 3});
  return Rz.matmul(Ry).matmul(Rx);
}

}  // namespace

int main(int argc, char** argv) {
  mallopt(M_MMAP_MAX, 0);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  torch::set_num_threads(int(std::thread::hardware_concurrency()));
  if (argc < 3) {
    std::fprintf(stderr, "usage: fit_solver_bench MODEL.safetensors LANDMARKS.json [IMAGE_SIZE]\n");
    return 2;
  }
  const MorphableModel model = read_model(argv[1]);
  const Landmarks lm = read_landmarks(argv[2]);
  const int size = argc > 3 ? std::atoi(argv[3]) : 256;
  const Camera camera = view_camera("front", size, Eigen::Vector3d::Zero());  // mm-fit's camera for a model
  LandmarkFitOptions options;
  std::printf("%-34s %17s %20s %20s %12s\n", "solver", "to 1 px", "to 0.1 px", "end", "RMS");

  // Ours: Levenberg–Marquardt, its own trace.
  const LandmarkFit lmfit = fit_landmarks(model, lm.points, camera, options);
  Progress ours;
  for (const FitTraceStep& t : lmfit.trace) ours.add(t.iteration, 1000 * t.seconds, t.value);
  ours.print("Levenberg-Marquardt (ours, Eigen)");

  // Adam on the same objective.
  const int Ka = std::min<int>(options.shape_components, int(model.shape_basis.rows()));
  const int Kb = std::min<int>(options.expression_components, int(model.expression_basis.rows()));
  const auto opts = torch::TensorOptions().dtype(torch::kDouble);
  torch::Tensor mean = torch::empty({68, 3}, opts), basis = torch::empty({68, 3, Ka + Kb}, opts);
  for (int k = 0; k < 68; ++k) {
    const int v = model.landmark_vertices[size_t(k)];
    for (int c = 0; c < 3; ++c) {
      mean[k][c] = model.topology.V(v, c);
      for (int j = 0; j < Ka; ++j) basis[k][c][j] = double(model.shape_basis(j, 3 * v + c)) * model.shape_stddev(j);
      for (int j = 0; j < Kb; ++j) basis[k][c][Ka + j] = double(model.expression_basis(j, 3 * v + c)) * model.expression_stddev(j);
    }
  }
  torch::Tensor target = torch::empty({68, 2}, opts);
  for (int k = 0; k < 68; ++k) target[k][0] = lm.points(k, 0), target[k][1] = lm.points(k, 1);
  const Eigen::Matrix3d Rc = camera.R;
  const torch::Tensor cam_R = torch::from_blob(const_cast<double*>(Rc.data()), {3, 3}, opts).t().clone();  // col-major
  const torch::Tensor cam_t = torch::tensor({camera.t.x(), camera.t.y(), camera.t.z()}, opts);
  for (const double lr : {0.01, 0.03, 0.1}) {
    torch::Tensor angles = torch::zeros({3}, opts).requires_grad_(true);
    torch::Tensor translation = torch::zeros({3}, opts).requires_grad_(true);
    torch::Tensor coeffs = torch::zeros({Ka + Kb}, opts).requires_grad_(true);
    // Per-group steps: radians, mm (100× the rate) and standardised coefficients (10×).
    torch::optim::Adam adam({torch::optim::OptimizerParamGroup({angles}, std::make_unique<torch::optim::AdamOptions>(lr)),
                             torch::optim::OptimizerParamGroup({translation}, std::make_unique<torch::optim::AdamOptions>(100 * lr)),
                             torch::optim::OptimizerParamGroup({coeffs}, std::make_unique<torch::optim::AdamOptions>(10 * lr))});
    Progress p;
    const auto t0 = std::chrono::steady_clock::now();
    for (int it = 0; it <= 3000; ++it) {
      adam.zero_grad();
      const torch::Tensor S = mean + basis.matmul(coeffs);                               // [68, 3]
      const torch::Tensor world = S.matmul(rotation(angles).t()) + translation;
      const torch::Tensor pc = world.matmul(cam_R.t()) + cam_t;                          // camera frame, z < 0 in front
      const torch::Tensor depth = -pc.select(1, 2);
      const torch::Tensor px = torch::stack({camera.cx + camera.focal * pc.select(1, 0) / depth,
                                             camera.cy - camera.focal * pc.select(1, 1) / depth}, 1);
      const torch::Tensor data = (px - target).pow(2).sum();
      const torch::Tensor loss = data + options.regularisation * coeffs.pow(2).sum();
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      p.add(it, ms, std::sqrt(data.item<double>() / 68));
      loss.backward();
      adam.step();
    }
    char name[64];
    std::snprintf(name, sizeof name, "Adam (LibTorch), lr %.2f", lr);
    p.print(name);
  }
  return 0;
}

}  // namespace bareskin_bench_fit_solver
