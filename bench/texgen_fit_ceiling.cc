// The ceiling of make-dataset's landmark levers (bench only; the dataset never sees truth): the same renders, fits and
// unwraps as `texgen make-dataset` (texgen::fit_views with the same options), but each view's landmarks are the
// subject's own landmark vertices projected by the render's camera instead of face-api's. Prints, per subject, the
// merged unwrap's PSNR vs the truth diffuse over the seen texels, each view's PSNR on its own coverage, and the fitted
// shape's error (mm).
//   texgen_fit_ceiling MODEL REGISTERED [render_size=1024] [input_res=1024] [silhouette_rounds=0]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/error.h"
#include "morphable/model.h"
#include "texgen/texture_sample.h"

using namespace bareskin;
using namespace bareskin::texgen;

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s MODEL REGISTERED [render_size] [input_res] [silhouette_rounds]\n", argv[0]);
    return 2;
  }
  try {
    const MorphableModel model = read_model(argv[1]);
    TextureSampleOptions options;
    options.render_size = argc > 3 ? std::atoi(argv[3]) : 1024;
    options.input_res = argc > 4 ? std::atoi(argv[4]) : 1024;
    options.silhouette.rounds = argc > 5 ? std::atoi(argv[5]) : 0;
    options.silhouette.weight = 0.3;
    options.check();
    const Camera camera = view_camera("front", options.render_size, Eigen::Vector3d::Zero(), 1000);
    std::vector<std::string> dirs;
    for (const auto& e : std::filesystem::directory_iterator(argv[2]))
      if (e.is_directory()) dirs.push_back(e.path().string());
    std::sort(dirs.begin(), dirs.end());
    double sum_psnr = 0, sum_shape = 0;
    for (const std::string& dir : dirs) {
      const Subject subject = load_subject(dir, model);
      // fit_views asks for the views' landmarks in view order, once each.
      size_t next = 0;
      const FaceLandmarkDetector truth = [&](const Image&) -> std::optional<Landmarks68> {
        const Eigen::Matrix3d R = view_rotation(options.views[next++ % options.views.size()]);
        Landmarks68 l;
        for (int k = 0; k < 68; ++k) {
          const Eigen::Vector3d p = camera.project(R * subject.mesh.V.row(model.landmark_vertices[size_t(k)]).transpose());
          l.row(k) << p.x(), p.y();
        }
        return l;
      };
      const std::vector<ViewFit> views = fit_views(model, subject, sample_light(0, 1), truth, options);
      std::vector<const UnwarpResult*> unwraps;
      for (const ViewFit& v : views) unwraps.push_back(&v.unwrap);
      const MergedUnwrap merged = merge_by_confidence(unwraps, options.merge_sharpness);
      const Image diffuse = resize_square(subject.diffuse, options.input_res);
      const double psnr = masked_psnr_srgb(merged.colour, diffuse, merged.confidence);
      std::printf("%s merged %.2f dB, shape %.2f mm, views", subject.name.c_str(), psnr, views[0].shape_error_mm);
      for (const ViewFit& v : views)
        std::printf(" %s %.2f dB (rms %.1f px)", v.name.c_str(), masked_psnr_srgb(v.unwrap.colour, diffuse, v.unwrap.confidence),
                    v.landmark_rms_px);
      std::printf("\n");
      sum_psnr += psnr;
      sum_shape += views[0].shape_error_mm;
    }
    std::printf("mean over %zu subjects: merged %.2f dB, shape %.2f mm\n", dirs.size(), sum_psnr / double(dirs.size()),
                sum_shape / double(dirs.size()));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "texgen_fit_ceiling: %s\n", e.what());
    return 1;
  }
  return 0;
}
