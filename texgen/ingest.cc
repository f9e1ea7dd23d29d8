#include "texgen/ingest.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>

#include "core/error.h"
#include "core/files.h"
#include "core/image_io.h"
#include "core/log.h"
#include "core/png.h"
#include "texgen/polygon.h"
#include "core/shards.h"

namespace bareskin::texgen {
namespace fs = std::filesystem;
namespace {

using Vec2 = Eigen::Vector2d;

// A landmark polygon into a 1-channel mask.
void fill_polygon(Image& mask, const std::vector<Vec2>& poly, float value) {
  bareskin::fill_polygon(poly, mask.width, mask.height, [&](int x, int y) { mask.at(x, y) = value; });
}

void fill_band(Image& mask, const std::vector<Vec2>& line, double radius, float value) {
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      const Vec2 p(x + 0.5, y + 0.5);
      for (size_t i = 0; i + 1 < line.size(); ++i) {
        const Vec2 ab = line[i + 1] - line[i];
        const double t = std::clamp((p - line[i]).dot(ab) / std::max(ab.squaredNorm(), 1e-12), 0.0, 1.0);
        if ((p - line[i] - t * ab).norm() <= radius) {
          mask.at(x, y) = value;
          break;
        }
      }
    }
}

std::vector<Vec2> points(const detect::Landmarks68& L, std::initializer_list<int> ids,
                         const Vec2& shift = Vec2::Zero()) {
  std::vector<Vec2> out;
  for (int k : ids) out.push_back(L.row(k).transpose() + shift);
  return out;
}

// An sRGB RGB photo with values in [0,1] whatever the file holds (grey, alpha, linear EXR).
Image read_photo(const std::string& path) {
  Image in = read_image(path);
  if (in.color_space == ColorSpace::Linear) in = to_srgb(in);
  Image out(in.width, in.height, 3, ColorSpace::sRGB);
  for (int y = 0; y < in.height; ++y)
    for (int x = 0; x < in.width; ++x)
      for (int c = 0; c < 3; ++c) out.at(x, y, c) = std::clamp(in.at(x, y, in.channels >= 3 ? c : 0), 0.0f, 1.0f);
  return out;
}

nlohmann::json points_json(const detect::Landmarks68& L) {
  nlohmann::json out = nlohmann::json::array();
  for (int k = 0; k < 68; ++k) out.push_back({L(k, 0), L(k, 1)});
  return out;
}

nlohmann::json similarity_json(const detect::Similarity& s) {
  const Eigen::Matrix<double, 2, 3> m = s.matrix();
  return {{m(0, 0), m(0, 1), m(0, 2)}, {m(1, 0), m(1, 1), m(1, 2)}};
}

struct AlignedPhoto {
  Image image;                 // 256² sRGB
  detect::Landmarks68 points;  // aligned pixels
  detect::Similarity similarity;
  double score = 0;
};

// Detects the best face and aligns the photo; false when no face is found.
bool align_photo(const std::string& path, const detect::PhotoDetector& detector, AlignedPhoto& out) {
  const Image photo = read_photo(path);
  const std::vector<detect::PhotoFace> faces = detector(photo);
  if (faces.empty()) return false;
  out.similarity = detect::alignment(faces.front().points);
  out.points = detect::transform(out.similarity, faces.front().points);
  out.image = detect::warp_aligned(photo, out.similarity);
  out.score = faces.front().score;
  return true;
}

}  // namespace

void IngestOptions::check() const {
  if (before_dir.empty() || after_dir.empty())
    throw InvalidInput("texgen ingest-pairs", "needs two folders", "give before/ after/");
  for (const std::string& d : {before_dir, after_dir})
    if (!fs::is_directory(d)) throw IoError(d, "is not a folder", "give the folder of before (or after) photos");
  if (output.empty()) throw InvalidInput("-o", "no output folder", "give -o shards/");
  if (shard_size < 1) throw InvalidInput("--shard-size", "must be at least 1", "use e.g. 100");
}

nlohmann::json IngestReport::to_json() const {
  return {{"pairs", pairs}, {"written", written}, {"unmatched", unmatched}, {"undetected", undetected}};
}

bool ycbcr_skin(float r, float g, float b) {
  const float R = 255 * r, G = 255 * g, B = 255 * b;
  const float cb = 128 - 0.168736f * R - 0.331264f * G + 0.5f * B;
  const float cr = 128 + 0.5f * R - 0.418688f * G - 0.081312f * B;
  return cb >= 77 && cb <= 127 && cr >= 133 && cr <= 173;
}

FaceMasks landmark_masks(const detect::Landmarks68& L, const Image& aligned) {
  const int w = aligned.width, h = aligned.height;
  const Vec2 chin = L.row(8).transpose(), bridge = L.row(27).transpose();
  const double height = (chin - bridge).norm();  // nose bridge to chin: about 0.6 of the face
  const Vec2 up = (bridge - chin).normalized();
  FaceMasks m{Image(w, h, 1, ColorSpace::Data), Image(w, h, 1, ColorSpace::Data)};
  // The hull: the jaw line, then the brows raised by a third of the face height (the forehead).
  std::vector<Vec2> hull = points(L, {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16});
  for (const Vec2& p : points(L, {26, 25, 24, 23, 22, 21, 20, 19, 18, 17}, up * 0.35 * height)) hull.push_back(p);
  fill_polygon(m.face, hull, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (m.face.at(x, y) > 0 && !ycbcr_skin(aligned.at(x, y, 0), aligned.at(x, y, 1), aligned.at(x, y, 2)))
        m.face.at(x, y) = 0;
  m.skin = m.face;
  fill_polygon(m.skin, points(L, {36, 37, 38, 39, 40, 41}), 0);
  fill_polygon(m.skin, points(L, {42, 43, 44, 45, 46, 47}), 0);
  fill_polygon(m.skin, points(L, {48, 49, 50, 51, 52, 53, 54, 55, 56, 57, 58, 59}), 0);
  const Vec2 down = -up * 0.025 * height;
  fill_band(m.skin, points(L, {17, 18, 19, 20, 21}, down), 0.05 * height, 0);
  fill_band(m.skin, points(L, {22, 23, 24, 25, 26}, down), 0.05 * height, 0);
  fill_band(m.skin, points(L, {31, 32, 33, 34, 35}, up * 0.02 * height), 0.035 * height, 0);
  // The eyes' rims: a pixel around the lid contours.
  fill_band(m.skin, points(L, {36, 37, 38, 39, 40, 41, 36}), 1.0, 0);
  fill_band(m.skin, points(L, {42, 43, 44, 45, 46, 47, 42}), 1.0, 0);
  return m;
}

std::vector<std::pair<std::string, std::string>> photos_by_stem(const std::string& dir) {
  static const char* const kExtensions[] = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".exr"};
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string ext = lower_extension(e.path().string());
    if (std::find(std::begin(kExtensions), std::end(kExtensions), ext) == std::end(kExtensions)) continue;
    out.emplace_back(e.path().stem().string(), e.path().string());
  }
  std::sort(out.begin(), out.end());
  return out;
}

IngestReport ingest_pairs(const IngestOptions& o, const detect::PhotoDetector& detector,
                          const ProgressCallback& progress) {
  o.check();
  BS_CHECK(bool(detector), "ingest_pairs needs a face detector");
  IngestReport report;
  std::map<std::string, std::string> before, after;
  const auto fill = [&](const std::string& dir, std::map<std::string, std::string>& into) {
    for (const auto& [stem, path] : photos_by_stem(dir)) {
      if (into.count(stem)) {
        throw InvalidInput(path, "has the same stem as " + into[stem], "keep one photo per name in each folder");
      }
      into[stem] = path;
    }
  };
  fill(o.before_dir, before);
  fill(o.after_dir, after);
  std::vector<std::string> stems;
  for (const auto& [stem, path] : before) {
    if (after.count(stem))
      stems.push_back(stem);
    else
      report.unmatched.push_back(path);
  }
  for (const auto& [stem, path] : after)
    if (!before.count(stem)) report.unmatched.push_back(path);
  if (!report.unmatched.empty() && !o.keep_going) {
    throw InvalidInput(report.unmatched.front(), "has no photo of the same name in the other folder",
                       "add its partner, remove it, or pass --keep-going to list and skip such photos");
  }
  report.pairs = int64_t(stems.size());
  if (stems.empty()) {
    throw InvalidInput(o.before_dir, "and " + o.after_dir + " share no photo name",
                       "pair before/after photos by file name (12.jpg with 12.png)");
  }

  AtomicDirectory out(o.output);
  std::vector<shards::ShardInfo> written;
  {
    shards::ShardWriter writer(out.path(), "faces", o.shard_size);
    for (size_t i = 0; i < stems.size(); ++i) {
      bareskin::report(progress, int64_t(i), int64_t(stems.size()), "ingest");
      AlignedPhoto a, b;
      std::string failed, why = "no face found";
      try {
        if (!align_photo(after[stems[i]], detector, a))
          failed = after[stems[i]];
        else if (!align_photo(before[stems[i]], detector, b))
          failed = before[stems[i]];
      } catch (const Error& e) {  // unreadable or corrupt photo: an error, or listed with --keep-going
        if (!o.keep_going) throw;
        failed = a.image.empty() ? after[stems[i]] : before[stems[i]];
        why = e.what();
      }
      if (!failed.empty()) {
        if (!o.keep_going) {
          throw InvalidInput(failed, "no face found", "use a photo with a visible frontal face, or pass --keep-going");
        }
        report.undetected.push_back(failed);
        spdlog::warn("{}: {}; the pair '{}' is skipped", failed, why, stems[i]);
        continue;
      }
      const FaceMasks masks = landmark_masks(a.points, a.image);
      nlohmann::json meta = {
          {"subject", "real/" + stems[i]},
          {"split", o.split},
          {"style", "unknown"},
          {"has_truth", false},
          {"landmarks", points_json(a.points)},
          {"landmarks_visible", std::vector<bool>(68, true)},
          {"align", {{"similarity", similarity_json(a.similarity)}, {"source", "detector"}}},
          {"camera", {{"focal", 1015.0 * 256 / 224}, {"cx", 128.0}, {"cy", 128.0}, {"width", 256}, {"height", 256}}},
          {"before",
           {{"landmarks", points_json(b.points)},
            {"align", {{"similarity", similarity_json(b.similarity)}, {"source", "detector"}}}}},
          {"detector_score", {{"after", a.score}, {"before", b.score}}},
          {"source",
           {{"before", fs::path(before[stems[i]]).filename().string()},
            {"after", fs::path(after[stems[i]]).filename().string()}}}};
      char key[16];
      std::snprintf(key, sizeof key, "%08lld", (long long)report.written);
      shards::Sample sample{key, {}};
      sample.members["makeup.png"] = encode_png(a.image);
      sample.members["before.png"] = encode_png(b.image);
      sample.members["skin.png"] = encode_png(masks.skin);
      sample.members["face.png"] = encode_png(masks.face);
      sample.members["json"] = meta.dump();
      writer.write(sample);
      ++report.written;
    }
    written = writer.finish();
  }
  if (report.written == 0) {
    throw InvalidInput(o.after_dir, "no pair has a face in both photos", "check the photos (frontal faces)");
  }
  shards::Manifest manifest;
  manifest.shards = written;
  manifest.metadata = {{"generator", o.generator},  {"kind", "faces"},        {"split", o.split},
                       {"has_truth", false},        {"before", o.before_dir}, {"after", o.after_dir},
                       {"report", report.to_json()}};
  shards::write_manifest(out.path(), manifest);
  write_file_atomic(out.path() + "/report.json", report.to_json().dump(1) + "\n");
  out.commit();
  bareskin::report(progress, int64_t(stems.size()), int64_t(stems.size()), "ingest");
  return report;
}

}  // namespace bareskin::texgen
