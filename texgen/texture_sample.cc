#include "texgen/texture_sample.h"

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <limits>
#include <random>

#include "core/error.h"
#include "core/image_io.h"
#include "core/mesh_io.h"
#include "core/scan_folder.h"
#include "core/similarity.h"
#include "core/parallel.h"
#include "render/rasterize.h"
#include "render/shade.h"
#include "render/sh.h"
#include "fitting/multiview_fit.h"

namespace bareskin::texgen {

namespace fs = std::filesystem;

void TextureSampleOptions::check() const {
  if (views.empty()) throw InvalidInput("--yaw", "no views", "give at least the front view");
  for (const ViewSpec& v : views)
    if (!(std::abs(v.yaw_deg) <= 80)) throw InvalidInput("--yaw", "yaw must lie in [-80, 80] degrees", "");
  if (fit_size < 64 || fit_size > 2048) throw InvalidInput("--fit-size", "must lie in [64, 2048]", "");
  if (render_size < fit_size || render_size % fit_size != 0 || render_size > 8192)
    throw InvalidInput("--render-size", "must be a multiple of the fit size (" + std::to_string(fit_size) + ") up to 8192",
                       "e.g. 1024");
  if (input_res < 16 || input_res > 16384) throw InvalidInput("--input-res", "must lie in [16, 16384]", "");
  if (!(merge_sharpness >= 0 && merge_sharpness <= 64)) throw InvalidInput("--merge-sharpness", "must lie in [0, 64]", "");
  if (landmark_fit_mode != "shared-shape" && landmark_fit_mode != "rigid" && landmark_fit_mode != "per-view")
    throw InvalidInput("--landmark-fit", "unknown mode '" + landmark_fit_mode + "'", "use shared-shape, rigid or per-view");
  if (landmark_robust_rounds < 0 || landmark_robust_rounds > 10)
    throw InvalidInput("--robust-landmarks", "must lie in [0, 10]", "e.g. 2");
  silhouette.check();
  if (silhouette.rounds > 0 && landmark_fit_mode != "shared-shape")
    throw InvalidInput("--silhouette-rounds", "the silhouette term refines the shared-shape fit only",
                       "pass --landmark-fit shared-shape or --silhouette-rounds 0");
  align.check();
  landmark_fit.check();
}

Subject load_subject_mesh(const std::string& dir, const MorphableModel& model) {
  Subject s;
  s.dir = dir;
  s.name = fs::path(dir).filename().string();
  const std::string mesh_path = find_scan_mesh(dir);
  if (mesh_path.empty())
    throw InvalidInput(dir, "holds no mesh.ply or mesh.obj", "give the folders `bareskin scan register` writes");
  const Mesh registered = read_mesh(mesh_path);
  if (registered.V.rows() != model.vertices() || registered.F.rows() != model.topology.F.rows() ||
      registered.F != model.topology.F) {
    throw InvalidInput(mesh_path,
                       std::to_string(registered.V.rows()) + " vertices and " + std::to_string(registered.F.rows()) +
                           " triangles, the model " + std::to_string(model.vertices()) + " and " +
                           std::to_string(model.topology.F.rows()) + ": registered to another template than the model's",
                       "register the scans with the model's template, or build the model from this folder");
  }
  // Rigid alignment onto the mean shape: the subject keeps its size (shape errors stay in mm).
  const Eigen::Matrix3Xd src = registered.V.transpose(), dst = model.topology.V.transpose();
  const Eigen::Matrix4d T = Eigen::umeyama(src, dst, false);
  s.mesh = model.topology;
  s.mesh.V = transformed(T, registered.V);
  s.mesh.N.resize(0, 3);
  return s;
}

Subject load_subject(const std::string& dir, const MorphableModel& model) {
  std::string diffuse_path;
  for (const char* name : {"diffuse.png", "diffuse.exr", "diffuse.tif", "diffuse.tiff"})
    if (diffuse_path.empty() && fs::exists(dir + "/" + name)) diffuse_path = dir + "/" + name;
  if (diffuse_path.empty())
    throw InvalidInput(dir, "has no diffuse map", "register the scan with its maps, or remove the subject");
  Subject s = load_subject_mesh(dir, model);
  Image diffuse = read_image(diffuse_path);
  if (diffuse.width != diffuse.height || diffuse.channels < 3)
    throw InvalidInput(diffuse_path, "is not a square RGB map", "give the registered diffuse map");
  s.diffuse = diffuse.color_space == ColorSpace::sRGB ? to_linear(diffuse) : diffuse;
  return s;
}

Eigen::Matrix3d view_rotation(const ViewSpec& view) {
  return Eigen::AngleAxisd(-view.yaw_deg * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

MergedUnwrap merge_by_confidence(const std::vector<const UnwarpResult*>& views, double sharpness) {
  if (views.empty()) throw InvalidInput("", "no views to merge", "");
  const int S = views[0]->colour.width;
  for (const UnwarpResult* v : views)
    if (v->colour.width != S || v->colour.height != S || v->confidence.width != S || v->confidence.height != S)
      throw InvalidInput("", "the unwrapped views differ in size", "unwrap every view at the same size");
  MergedUnwrap m{Image(S, S, 3, ColorSpace::Linear), Image(S, S, 1, ColorSpace::Data)};
  parallel_for(0, int64_t(S) * S, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      double sum[3] = {0, 0, 0}, weights = 0;
      float best = 0;
      for (const UnwarpResult* v : views) {
        const float c = v->confidence.pixels[size_t(i)];
        if (c <= 0) continue;
        const double w = std::pow(double(c), sharpness);
        for (int k = 0; k < 3; ++k) sum[k] += w * v->colour.pixels[3 * size_t(i) + size_t(k)];
        weights += w;
        best = std::max(best, c);
      }
      if (weights <= 0) continue;
      for (int k = 0; k < 3; ++k) m.colour.pixels[3 * size_t(i) + size_t(k)] = float(sum[k] / weights);
      m.confidence.pixels[size_t(i)] = best;
    }
  }, 4096);
  return m;
}

ModelUvMaps model_uv_maps(const MorphableModel& model, const Coefficients& fit, int size, const RasterOutput* uv_raster) {
  ModelUvMaps maps;
  Mesh shape = model.topology;
  shape.V = model.shape(fit.alpha, fit.beta);
  const Eigen::MatrixX3d N = vertex_normals(shape.V, shape.F);
  RasterOutput own_uv;
  const RasterOutput& uv = given_or_own_uv(uv_raster, shape, size, own_uv);
  maps.normal = Image(size, size, 3, ColorSpace::Data);
  maps.position = Image(size, size, 3, ColorSpace::Data);
  parallel_for(0, int64_t(size) * size, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      const int32_t f = uv.triangle[size_t(i)];
      if (f < 0) continue;
      const double w[3] = {1.0 - uv.bary[2 * size_t(i)] - uv.bary[2 * size_t(i) + 1], uv.bary[2 * size_t(i)],
                           uv.bary[2 * size_t(i) + 1]};
      Eigen::Vector3d p = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
      for (int k = 0; k < 3; ++k) {
        p += w[k] * shape.V.row(shape.F(f, k)).transpose();
        n += w[k] * N.row(shape.F(f, k)).transpose();
      }
      n.normalize();
      for (int k = 0; k < 3; ++k) {
        maps.normal.pixels[3 * size_t(i) + size_t(k)] = float((n[k] + 1) / 2);
        maps.position.pixels[3 * size_t(i) + size_t(k)] =
            float(std::clamp((p[k] - maps.position_offset) / maps.position_scale, 0.0, 1.0));
      }
    }
  }, 4096);
  const Image appearance = appearance_image(model, fit);
  if (!appearance.empty()) {
    maps.albedo = resize_square(appearance, size);
    for (int64_t i = 0; i < int64_t(size) * size; ++i)
      if (uv.triangle[size_t(i)] < 0)
        for (int k = 0; k < 3; ++k) maps.albedo.pixels[3 * size_t(i) + size_t(k)] = 0;
  }
  return maps;
}

namespace {

double uniform(std::mt19937_64& rng, double lo, double hi) {  // portable: not std::uniform_real_distribution
  return lo + (hi - lo) * double(rng() >> 11) * 0x1.0p-53;
}

// Mean distance between two vertex sets of the same topology after the rigid alignment of `a` onto `b`.
double aligned_distance(const Eigen::MatrixX3d& a, const Eigen::MatrixX3d& b) {
  const Eigen::Matrix4d T = Eigen::umeyama(Eigen::Matrix3Xd(a.transpose()), Eigen::Matrix3Xd(b.transpose()), false);
  const Eigen::MatrixX3d moved = transformed(T, a);
  return (moved - b).rowwise().norm().mean();
}

}  // namespace

std::array<double, 27> sample_light(int l, uint64_t seed) {
  if (l == 0) return default_lighting();
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + uint64_t(l));
  std::array<double, 27> g{};
  const Eigen::Vector3d dir = Eigen::Vector3d(uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, 0.2, 1)).normalized();
  const double strength = uniform(rng, 0.1, 0.4);
  for (int c = 0; c < 3; ++c) {
    const double tint = uniform(rng, 0.9, 1.1);
    g[size_t(9 * c)] = kDeep3dAmbient * tint;
    // Basis 1..3 are −y, z, −x (render/sh.h): a light from `dir`.
    g[size_t(9 * c + 1)] = -strength * dir.y();
    g[size_t(9 * c + 2)] = strength * dir.z();
    g[size_t(9 * c + 3)] = -strength * dir.x();
  }
  for (int k = 4; k < 9; ++k) {
    const double v = uniform(rng, -0.05, 0.05);
    for (int c = 0; c < 3; ++c) g[size_t(9 * c + k)] = v;
  }
  return g;
}

Landmarks68 true_landmarks(const MorphableModel& model, const Subject& subject, const ViewSpec& view,
                           const Camera& camera, const Eigen::Matrix<double, 68, 3>* offsets) {
  const Eigen::Matrix3d R = view_rotation(view);
  Landmarks68 out;
  for (int k = 0; k < 68; ++k) {
    Eigen::Vector3d X = subject.mesh.V.row(model.landmark_vertices[size_t(k)]).transpose();
    if (offsets) X += offsets->row(k).transpose();
    const Eigen::Vector3d q = camera.project(R * X);
    out.row(k) << q.x(), q.y();
  }
  return out;
}

double masked_psnr_srgb(const Image& a, const Image& b, const Image& mask) {
  BS_CHECK(a.width == b.width && a.height == b.height && a.width == mask.width && a.height == mask.height,
           "psnr: sizes differ");
  double se = 0;
  int64_t n = 0;
  for (int64_t i = 0; i < int64_t(a.width) * a.height; ++i) {
    if (mask.pixels[size_t(i) * size_t(mask.channels)] <= 0) continue;
    for (int k = 0; k < 3; ++k) {
      const double d = linear_to_srgb(std::clamp(a.pixels[size_t(i) * size_t(a.channels) + size_t(k)], 0.f, 1.f)) -
                       linear_to_srgb(std::clamp(b.pixels[size_t(i) * size_t(b.channels) + size_t(k)], 0.f, 1.f));
      se += d * d;
    }
    ++n;
  }
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  return se == 0 ? std::numeric_limits<double>::infinity() : 10 * std::log10(1.0 / (se / (3.0 * double(n))));
}

namespace {

// A view rendered and its landmarks detected; the linear images stay for the photometric fit and the unwrap.
struct RenderedView {
  ViewFit fit;
  Eigen::Matrix3d rotation;
  Image photo, unwrapped;  // linear
  Image face;              // the render's face mask (1 where the face covers the pixel, 0 on the black background)
};

RenderedView render_view(const MorphableModel& model, const Subject& subject, const ViewSpec& view,
                         const std::array<double, 27>& light, const FaceLandmarkDetector& detect, const Camera& camera,
                         const TextureSampleOptions& options) {
  RenderedView out;
  out.fit.name = view.name;
  out.fit.yaw_deg = view.yaw_deg;
  out.rotation = view_rotation(view);
  const std::string where = subject.dir + " (" + view.name + " view, yaw " + std::to_string(int(view.yaw_deg)) + ")";
  // The subject turned by the view's yaw, seen by the canonical camera.
  Mesh turned = subject.mesh;
  turned.V = (subject.mesh.V * out.rotation.transpose()).eval();
  ShadeOptions shade;
  shade.texture = &subject.diffuse;
  shade.gamma = light;
  Frame frame = render_frame(turned, camera, shade);
  out.fit.render = to_srgb(frame.colour);
  out.fit.bare = to_srgb(frame.albedo);
  out.face = std::move(frame.mask);
  out.unwrapped = options.unwrap_lit ? frame.colour : std::move(frame.albedo);  // inference: BareSkinNet's bare skin
  out.photo = std::move(frame.colour);  // what the detector and the fits see (inference: the photo)

  const std::optional<Landmarks68> found = detect(out.fit.render);
  if (!found) throw InvalidInput(where, "no face found in the render", "use smaller yaw angles, or check the subject's maps");
  out.fit.detected = *found;
  out.fit.landmarks = *found;
  if (options.view_calibration)
    out.fit.landmarks = calibrated_landmarks(
        *found, options.view_calibration->at(view.name, view.yaw_deg, options.view_calibration_source), options.render_size);
  const Landmarks68 plain = true_landmarks(model, subject, view, camera, nullptr);
  double detector_error = 0;
  for (int k = 0; k < 68; ++k) detector_error += (plain.row(k) - out.fit.detected.row(k)).norm();
  out.fit.detector_error_px = detector_error / 68;
  out.fit.truth_landmarks = options.landmark_offsets
                                ? true_landmarks(model, subject, view, camera, &*options.landmark_offsets)
                                : plain;
  return out;
}

}  // namespace

std::vector<ViewFit> fit_views(const MorphableModel& model, const Subject& subject, const std::array<double, 27>& light,
                               const FaceLandmarkDetector& detect, const TextureSampleOptions& options,
                               const RasterOutput* uv_raster) {
  const Camera camera = view_camera("front", options.render_size, Eigen::Vector3d::Zero(), 1000);
  std::vector<RenderedView> views;
  for (const ViewSpec& v : options.views) views.push_back(render_view(model, subject, v, light, detect, camera, options));
  const Eigen::Matrix<double, 68, 3>* offsets = options.landmark_offsets ? &*options.landmark_offsets : nullptr;
  // The landmark fits: one for all views, or one per view (each a one-view joint fit in that view's own frame).
  std::vector<Coefficients> geometry;
  std::vector<LandmarkViewInput> anchors;  // the landmarks and their final weights, for the view alignment
  std::vector<double> rms;
  if (options.landmark_fit_mode != "per-view") {
    std::vector<LandmarkViewInput> inputs;
    for (const RenderedView& v : views) inputs.push_back({v.rotation, v.fit.landmarks});
    MultiviewLandmarkFit fit =
        fit_landmarks_multiview_robust(model, inputs, camera, options.landmark_fit,
                                       options.landmark_fit_mode == "shared-shape", offsets, options.landmark_robust_rounds);
    if (options.silhouette.rounds > 0) {  // reweighted each round when the landmark fit was
      std::vector<const Image*> renders;
      for (const RenderedView& v : views) renders.push_back(&v.fit.render);
      fit = refine_with_silhouettes(model, inputs, renders, camera, options.landmark_fit, offsets, std::move(fit),
                                    options.silhouette, options.landmark_robust_rounds > 0);
    }
    for (size_t v = 0; v < views.size(); ++v) {
      geometry.push_back(view_coefficients(fit, v));
      anchors.push_back({Eigen::Matrix3d::Identity(), views[v].fit.landmarks, fit.weight.row(Eigen::Index(v)).transpose()});
    }
    rms = fit.rms_px;
  } else if (offsets) {
    for (const RenderedView& v : views) {
      const MultiviewLandmarkFit fit =
          fit_landmarks_multiview_robust(model, {{Eigen::Matrix3d::Identity(), v.fit.landmarks}}, camera,
                                         options.landmark_fit, true, offsets, options.landmark_robust_rounds);
      geometry.push_back(view_coefficients(fit, 0));
      rms.push_back(fit.rms_px[0]);
    }
  } else {
    for (const RenderedView& v : views) {
      const LandmarkFit lm = fit_landmarks(model, v.fit.landmarks, camera, options.landmark_fit);
      Coefficients c;
      c.alpha = lm.alpha;
      c.beta = lm.beta;
      c.rotation = lm.rotation;
      c.translation = lm.translation;
      geometry.push_back(c);
      rms.push_back(lm.rms_px);
    }
  }
  if (options.align.rounds > 0) {
    std::vector<const Image*> unwrapped;
    for (const RenderedView& v : views) unwrapped.push_back(&v.unwrapped);
    ViewAlignmentOptions align = options.align;
    align.sharpness = options.merge_sharpness;
    align.shape = align.shape && options.landmark_fit_mode != "per-view";
    if (anchors.empty())
      for (const RenderedView& v : views) anchors.push_back({Eigen::Matrix3d::Identity(), v.fit.landmarks});
    ViewAlignment aligned = align_views_photometric(model, geometry, unwrapped, camera, align, anchors, offsets);
    geometry = std::move(aligned.views);
    for (size_t i = 0; i < views.size(); ++i) {
      views[i].fit.alignment_rms_before = aligned.rms_before[i];
      views[i].fit.alignment_rms_after = aligned.rms_after[i];
    }
  }
  std::vector<ViewFit> out;
  const Camera small = view_camera("front", options.fit_size, Eigen::Vector3d::Zero(), 1000);
  RasterOutput own_uv;
  const RasterOutput& uv = given_or_own_uv(uv_raster, model.topology, options.input_res, own_uv);
  for (size_t i = 0; i < views.size(); ++i) {
    ViewFit& v = views[i].fit;
    v.fit = geometry[i];
    v.landmark_rms_px = rms[i];
    const Mesh posed = posed_mesh(model, v.fit);
    const PhotometricFit photometric =
        fit_photometric(model, posed, small, resize_square(views[i].photo, options.fit_size), options.photometric);
    v.fit.delta = photometric.delta;
    v.fit.gamma = photometric.gamma;
    v.photometric_psnr_db = photometric.psnr_db;
    v.shape_error_mm = aligned_distance(model.shape(v.fit.alpha, v.fit.beta), subject.mesh.V);
    UnwarpOptions unwarp_options;
    unwarp_options.size = options.input_res;
    if (options.drop_background) unwarp_options.inside = &views[i].face;  // texels touching the background: unseen
    unwarp_options.uv_raster = &uv;
    v.unwrap = unwarp(views[i].unwrapped, posed, camera, unwarp_options);
    out.push_back(std::move(v));
  }
  return out;
}

}  // namespace bareskin::texgen
