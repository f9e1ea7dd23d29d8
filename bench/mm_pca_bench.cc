// mm_pca_bench TEMPLATE_DIR SUBJECTS OUT_DIR [COMPONENTS] [--write-registered]: a population of identities sampled on the template (the
// `scan synth` identity model, perfectly registered), written as OUT_DIR/data.safetensors ("X" F32 [n, 3V]); then
// our shape PCA on it, timed (median of 3), with the result in OUT_DIR/ours.safetensors ("basis" F64 [k, 3V],
// "variance" F64 [k]) for bench/mm_pca.py to compare with numpy. --write-registered also writes each subject, moved by
// a random rigid motion, as OUT_DIR/registered/subject_NNNN/mesh.ply (template topology) for bench/mm_build.sh.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include <Eigen/Geometry>
#include <random>

#include "core/files.h"
#include "core/mesh_io.h"
#include "core/safetensors.h"
#include "morphable/pca.h"
#include "scan/identity.h"

int main(int argc, char** argv) {
  using namespace bareskin;
  if (argc < 4) {
    std::fprintf(stderr, "usage: mm_pca_bench TEMPLATE_DIR SUBJECTS OUT_DIR [COMPONENTS]\n");
    return 2;
  }
  const std::string dir = argv[1], out = argv[3];
  const int n = std::stoi(argv[2]), k = argc > 4 ? std::stoi(argv[4]) : 120;
  const bool write_registered = argc > 5 && std::string(argv[5]) == "--write-registered";
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-0.2, 0.2), shift(-20, 20);
  const TemplateFace face = read_template(dir + "/face.obj", dir + "/landmarks.json");
  const Eigen::Index V = face.mesh.V.rows();
  RowMatrixXf X(n, 3 * V);
  for (int i = 0; i < n; ++i) {
    const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> S = face.mesh.V + sample_identity(face, 1000 + uint64_t(i)).displacement;
    X.row(i) = Eigen::Map<const Eigen::RowVectorXd>(S.data(), 3 * V).cast<float>();
    if (write_registered) {
      const Eigen::Matrix3d R = (Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitX())).toRotationMatrix();
      Mesh m = face.mesh;
      m.V = (S * R.transpose()).rowwise() + Eigen::RowVector3d(shift(rng), shift(rng), shift(rng));
      m.N = vertex_normals(m.V, m.F);
      char id[32];
      std::snprintf(id, sizeof id, "/registered/subject_%04d", i);
      make_directories(out + id);
      write_mesh(out + id + "/mesh.ply", m);
    }
  }
  SafeTensorsWriter data;
  data.add("X", DType::F32, {n, 3 * V}, X.data(), size_t(X.size()) * sizeof(float));
  data.write(out + "/data.safetensors");

  std::vector<double> seconds;
  Pca p;
  for (int run = 0; run < 3; ++run) {
    const auto t0 = std::chrono::steady_clock::now();
    p = pca(X, std::min(k, n - 1), 0, "bench");
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  std::sort(seconds.begin(), seconds.end());
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> basis = p.basis;
  SafeTensorsWriter ours;
  ours.add("basis", DType::F64, {basis.rows(), basis.cols()}, basis.data(), size_t(basis.size()) * sizeof(double));
  ours.add("variance", DType::F64, {p.variance.size()}, p.variance.data(), size_t(p.variance.size()) * sizeof(double));
  ours.write(out + "/ours.safetensors");
  std::printf("%d subjects x %lld numbers, %d components: ours %.3f s (median of 3)\n", n, (long long)(3 * V),
              int(p.variance.size()), seconds[1]);
  return 0;
}
