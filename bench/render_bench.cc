// render_bench TEMPLATE_DIR [FRAMES]: the CPU rasterizer on the template (front view, Deep3DFaceRecon camera), at 256²
// and 1024², median milliseconds per frame over FRAMES frames (4 views a batch, each projected anew), and the
// attribute interpolation of the vertex normals at the same sizes.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

#include "core/parallel.h"
#include "template/template_face.h"
#include "render/rasterize.h"

int main(int argc, char** argv) {
  using namespace bareskin;
  if (argc < 2) {
    std::fprintf(stderr, "usage: render_bench TEMPLATE_DIR [FRAMES]\n");
    return 2;
  }
  const std::string dir = argv[1];
  const int frames = argc > 2 ? std::stoi(argv[2]) : 40;
  const TemplateFace face = read_template(dir + "/face.obj", dir + "/landmarks.json");
  const Eigen::Matrix<int32_t, Eigen::Dynamic, 3, Eigen::RowMajor> F = face.mesh.F;
  const Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> N = vertex_normals(face.mesh.V, face.mesh.F).cast<float>();
  const Eigen::Vector3d centre = face.mesh.V.colwise().mean().transpose();
  std::printf("template %lld vertices, %lld triangles, %d threads\n", (long long)face.mesh.V.rows(),
              (long long)face.mesh.F.rows(), num_threads());
  for (int size : {256, 1024}) {
    std::vector<double> raster_ms, interp_ms;
    int64_t covered = 0;
    for (int i = 0; i < frames; ++i) {
      const Camera cam = view_camera(i % 4 == 3 ? "left" : "front", size, centre, 1000 + 10 * (i % 4));
      const auto t0 = std::chrono::steady_clock::now();
      std::vector<float> z;
      const std::vector<float> xyw = project_vertices(face.mesh.V, cam, z);
      RasterInput in;
      in.xyw = xyw.data();
      in.triangles = F.data();
      in.vertex_count = face.mesh.V.rows();
      in.triangle_count = face.mesh.F.rows();
      in.width = in.height = size;
      const RasterOutput r = rasterize(in);
      const auto t1 = std::chrono::steady_clock::now();
      const std::vector<float> n = interpolate(r, F.data(), N.data(), 3);
      const auto t2 = std::chrono::steady_clock::now();
      raster_ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
      interp_ms.push_back(std::chrono::duration<double, std::milli>(t2 - t1).count());
      covered = std::count_if(r.triangle.begin(), r.triangle.end(), [](int32_t t) { return t >= 0; });
    }
    std::sort(raster_ms.begin(), raster_ms.end());
    std::sort(interp_ms.begin(), interp_ms.end());
    std::printf("%4d²: project + rasterize %.2f ms/frame (median of %d), interpolate normals %.2f ms; %lld pixels covered\n",
                size, raster_ms[raster_ms.size() / 2], frames, interp_ms[interp_ms.size() / 2], (long long)covered);
  }
  return 0;
}
