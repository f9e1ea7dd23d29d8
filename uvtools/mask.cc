#include "uvtools/mask.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <sstream>

#include "core/error.h"
#include "render/shade.h"
#include "uvtools/unwarp.h"

namespace bareskin {
namespace {

using Vec = Eigen::Vector2d;

Vec mean_of(const std::vector<Vec>& p, int a, int b) {
  Vec m = Vec::Zero();
  for (int k = a; k <= b; ++k) m += p[size_t(k)];
  return m / double(b - a + 1);
}

// Labels every pixel of [x0, x1] x [y0, y1] (clamped) whose centre satisfies `inside`.
void paint(LabelImage& img, double x0, double x1, double y0, double y1, uint8_t label,
           const std::function<bool(const Vec&)>& inside) {
  const int a = std::max(0, int(std::floor(x0))), b = std::min(img.width - 1, int(std::ceil(x1)));
  const int c = std::max(0, int(std::floor(y0))), d = std::min(img.height - 1, int(std::ceil(y1)));
  for (int y = c; y <= d; ++y)
    for (int x = a; x <= b; ++x)
      if (inside(Vec(x + 0.5, y + 0.5))) img.label[size_t(y) * size_t(img.width) + size_t(x)] = label;
}

void ellipse(LabelImage& img, const Vec& c, double rx, double ry, double angle, uint8_t label) {
  const double r = std::max(rx, ry), ca = std::cos(angle), sa = std::sin(angle);
  paint(img, c.x() - r, c.x() + r, c.y() - r, c.y() + r, label, [&](const Vec& p) {
    const Vec q = p - c;
    const double u = ca * q.x() + sa * q.y(), v = -sa * q.x() + ca * q.y();
    return (u * u) / (rx * rx) + (v * v) / (ry * ry) <= 1;
  });
}

// A thick segment with round ends.
void capsule(LabelImage& img, const Vec& a, const Vec& b, double radius, uint8_t label) {
  paint(img, std::min(a.x(), b.x()) - radius, std::max(a.x(), b.x()) + radius, std::min(a.y(), b.y()) - radius,
        std::max(a.y(), b.y()) + radius, label, [&](const Vec& p) {
          const Vec ab = b - a;
          const double t = std::clamp((p - a).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
          return (p - (a + t * ab)).norm() <= radius;
        });
}

}  // namespace

bool is_face_surface(uint8_t l) {
  return l == kSkin || l == kNose || l == kLeftEye || l == kRightEye || l == kLeftBrow || l == kRightBrow ||
         l == kMouth || l == kUpperLip || l == kLowerLip;
}

const char* to_string(Occluder o) {
  switch (o) {
    case Occluder::Hair: return "hair";
    case Occluder::Glasses: return "glasses";
    case Occluder::Hand: return "hand";
    case Occluder::Hat: return "hat";
  }
  return "?";
}

std::vector<Occluder> parse_occluders(const std::string& list) {
  std::vector<Occluder> out;
  std::stringstream in(list);
  for (std::string item; std::getline(in, item, ',');) {
    if (item == "hair") out.push_back(Occluder::Hair);
    else if (item == "glasses") out.push_back(Occluder::Glasses);
    else if (item == "hand") out.push_back(Occluder::Hand);
    else if (item == "hat") out.push_back(Occluder::Hat);
    else throw InvalidInput("", "unknown occluder '" + item + "'", "use hair, glasses, hand, hat");
  }
  return out;
}

void draw_occluder(LabelImage& img, Occluder occluder, const std::vector<Vec>& lm, std::mt19937_64& rng) {
  if (lm.size() != 68) throw InvalidInput("", "occluders need the 68 iBUG landmarks", "give the template's landmarks");
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const auto uniform = [&](double a, double b) { return a + (b - a) * U(rng); };
  const Vec eye_r = mean_of(lm, 36, 41), eye_l = mean_of(lm, 42, 47);  // the subject's right and left eyes
  const double d = std::max((eye_l - eye_r).norm(), 1.0);                // inter-ocular distance, pixels
  const Vec mid = 0.5 * (eye_r + eye_l);
  const Vec across = (eye_l - eye_r) / d, down(-across.y(), across.x());  // image-space face axes
  double brow = 0;  // how far "up" the brows are, along -down
  for (int k = 17; k <= 26; ++k) brow += (lm[size_t(k)] - mid).dot(down) / 10;
  const double left = (lm[0] - mid).dot(across), right = (lm[16] - mid).dot(across);
  const auto face_xy = [&](const Vec& p) { return Vec((p - mid).dot(across), (p - mid).dot(down)); };
  const double W = img.width + img.height;
  switch (occluder) {
    case Occluder::Hair: {  // a fringe: everything above a wavy line near the brows, dropping at the sides
      const double offset = uniform(-0.2, 0.35) * d, amplitude = uniform(0.03, 0.12) * d, frequency = uniform(3, 9) / d,
                   phase = uniform(0, 2 * M_PI), drop = uniform(0.0, 0.8) * d, half = 0.5 * (right - left);
      paint(img, -W, W, -W, W, kHair, [&](const Vec& p) {
        const Vec q = face_xy(p);
        const double s = std::clamp((q.x() - 0.5 * (left + right)) / half, -1.5, 1.5);
        const double edge = brow - offset + amplitude * std::sin(frequency * q.x() + phase) + drop * std::pow(std::abs(s), 4);
        return q.y() < edge && q.x() > left - 0.6 * d && q.x() < right + 0.6 * d;
      });
      break;
    }
    case Occluder::Glasses: {
      const double w = std::max((lm[39] - lm[36]).norm(), (lm[45] - lm[42]).norm());
      const double rx = uniform(0.8, 1.1) * w, ry = rx * uniform(0.6, 0.85), thick = uniform(0.03, 0.06) * d;
      const double angle = std::atan2(across.y(), across.x());
      for (const Vec& c : {eye_r, eye_l}) ellipse(img, c + uniform(-0.05, 0.1) * d * down, rx, ry, angle, kGlasses);
      capsule(img, eye_r + rx * across, eye_l - rx * across, thick, kGlasses);  // the bridge
      capsule(img, eye_r - rx * across, mid + (left - 0.3 * d) * across, thick, kGlasses);   // the arms
      capsule(img, eye_l + rx * across, mid + (right + 0.3 * d) * across, thick, kGlasses);
      break;
    }
    case Occluder::Hand: {  // a palm on the chin, a cheek or the mouth, with four fingers
      const int anchors[] = {8, 4, 12, 57, 3, 13};
      const Vec centre = lm[size_t(anchors[std::uniform_int_distribution<int>(0, 5)(rng)])] +
                         d * Vec(uniform(-0.3, 0.3), uniform(-0.2, 0.4));
      const double a = uniform(0.55, 0.85) * d, b = a * uniform(0.6, 0.8), angle = uniform(0, 2 * M_PI);
      ellipse(img, centre, a, b, angle, kHand);
      const Vec dir(std::cos(angle), std::sin(angle)), side(-dir.y(), dir.x());
      const double length = uniform(0.6, 1.0) * d, radius = 0.08 * d;
      for (int f = 0; f < 4; ++f) {
        const Vec base = centre + 0.8 * a * dir + (f - 1.5) * 0.45 * b * side;
        capsule(img, base, base + length * (1 - 0.15 * std::abs(f - 1.5)) * dir, radius, kHand);
      }
      break;
    }
    case Occluder::Hat: {  // a brim: everything above a gently curved line over the forehead
      const double height = uniform(0.05, 0.6) * d, curve = uniform(0.02, 0.1) / d;
      paint(img, -W, W, -W, W, kHat, [&](const Vec& p) {
        const Vec q = face_xy(p);
        return q.y() < brow - height + curve * (q.x() - 0.5 * (left + right)) * (q.x() - 0.5 * (left + right));
      });
      break;
    }
  }
}

LabelImage label_image(const Image& img, const std::string& source) {
  if (img.channels != 1) {
    throw InvalidInput(source, "has " + std::to_string(img.channels) + " channels; labels are one channel of class indices",
                       "convert the label map to a single-channel index PNG");
  }
  LabelImage labels;
  labels.width = img.width;
  labels.height = img.height;
  labels.label.reserve(img.pixels.size());
  for (float v : img.pixels) {
    const long l = std::lround(v * 255);
    if (l < 0 || l > kHand) throw InvalidInput(source, "holds label " + std::to_string(l) + ", outside 0-19", "use CelebAMask-HQ indices");
    labels.label.push_back(uint8_t(l));
  }
  return labels;
}

Image to_image(const LabelImage& labels) {
  Image out(labels.width, labels.height, 1, ColorSpace::Data);
  for (size_t i = 0; i < labels.label.size(); ++i) out.pixels[i] = labels.label[i] / 255.f;
  return out;
}

LabelImage synthetic_labels(const Mesh& mesh, const Camera& camera, const std::vector<int>& landmark_vertices,
                            const std::vector<Occluder>& occluders, uint64_t seed) {
  std::vector<Eigen::Vector2d> lm;
  for (int id : landmark_vertices) {
    if (id < 0 || id >= mesh.V.rows()) throw InvalidInput("landmarks", "vertex id " + std::to_string(id) + " is outside the mesh", "");
    const Eigen::Vector3d p = camera.project(mesh.V.row(id).transpose());
    lm.emplace_back(p.x(), p.y());
  }
  LabelImage labels;
  labels.width = camera.width;
  labels.height = camera.height;
  const Frame frame = render_frame(mesh, camera, ShadeOptions());
  for (float m : frame.mask.pixels) labels.label.push_back(m > 0 ? kSkin : kBackground);
  std::mt19937_64 rng(seed);
  for (Occluder o : occluders) draw_occluder(labels, o, lm, rng);
  return labels;
}

std::vector<uint8_t> uv_face_mask(const LabelImage& labels, const Mesh& mesh, const Camera& camera, int size,
                                  int64_t* kept, const RasterOutput* uv_raster) {
  if (labels.width != camera.width || labels.height != camera.height) {
    throw InvalidInput("", "the label image is " + std::to_string(labels.width) + "x" + std::to_string(labels.height) +
                               ", the camera " + std::to_string(camera.width) + "x" + std::to_string(camera.height),
                       "give labels of the image the camera belongs to");
  }
  Image face(labels.width, labels.height, 1, ColorSpace::Data);
  for (size_t i = 0; i < labels.label.size(); ++i) face.pixels[i] = is_face_surface(labels.label[i]) ? 1.f : 0.f;
  UnwarpOptions options;
  options.size = size;
  options.uv_raster = uv_raster;
  const UnwarpResult r = unwarp(face, mesh, camera, options);
  std::vector<uint8_t> mask(size_t(size) * size_t(size), 0);
  int64_t n = 0;
  for (size_t i = 0; i < mask.size(); ++i) {
    mask[i] = r.confidence.pixels[i] > 0 && r.colour.pixels[3 * i] > 0.5f;
    n += mask[i];
  }
  if (kept) *kept = n;
  return mask;
}

}  // namespace bareskin
