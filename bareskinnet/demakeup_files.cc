#include "bareskinnet/demakeup_files.h"

#include <algorithm>
#include <cctype>
#include <chrono>
#include <filesystem>

#include "core/error.h"
#include "core/image_io.h"
#include "core/log.h"

namespace bareskin::bsn {
namespace fs = std::filesystem;

namespace {

bool is_photo(const fs::path& p) {
  std::string ext = p.extension().string();
  for (auto& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg" || ext == ".tif" || ext == ".tiff";
}

Image read_rgb(const std::string& photo) {
  Image image = read_image(photo);
  if (image.channels < 3) throw InvalidInput(photo, "is not an RGB photo", "give a colour photo");
  return image;
}

Image read_aligned(const std::string& photo) {
  Image image = read_rgb(photo);
  if (image.width != detect::kAlignedSize || image.height != detect::kAlignedSize)
    throw InvalidInput(photo, "is " + std::to_string(image.width) + "×" + std::to_string(image.height) +
                                  ", not an aligned " + std::to_string(detect::kAlignedSize) + "² face",
                       "drop --aligned for photos");
  return image;
}

}  // namespace

void DemakeupFilesOptions::check() const {
  if (input.empty()) throw InvalidInput("input", "is missing", "give a photo or a folder of photos");
  if (output.empty()) throw InvalidInput("-o", "is missing", "give the output folder");
  if (run.empty()) throw InvalidInput("--run", "is missing", "give the 'bareskin train bareskin' run");
  if (uv_size < 16 || uv_size > 16384)
    throw InvalidInput("--uv-size", std::to_string(uv_size) + " is outside [16, 16384]", "use e.g. 1024");
}

DemakeupFilesReport demakeup_files(const DemakeupFilesOptions& o, const detect::PhotoDetector& detector,
                                   const ProgressCallback& progress) {
  o.check();
  if (!fs::exists(o.input)) throw IoError(o.input, "does not exist", "give a photo or a folder of photos");
  std::vector<fs::path> photos;
  const bool folder = fs::is_directory(o.input);
  if (folder) {
    for (const auto& e : fs::directory_iterator(o.input))
      if (e.is_regular_file() && is_photo(e.path())) photos.push_back(e.path());
    std::sort(photos.begin(), photos.end());
    if (photos.empty()) throw InvalidInput(o.input, "holds no PNG/JPEG/TIFF photo", "give a photo or a folder of photos");
  } else {
    photos.push_back(o.input);
  }
  // A single input fails before the networks load: a wrong size (aligned) or no face (photo).
  if (!folder && o.aligned) read_aligned(photos[0].string());
  if (!folder && !o.aligned && detector(read_rgb(photos[0].string())).empty())
    throw InvalidInput(photos[0].string(), "no face was found", "give a photo with a face of at least ~80 px");
  Demakeup d = Demakeup::load(o.run, o.teacher, o.model, torch::Device(o.device));
  d.skip_g = o.without_g;
  d.flip_average = o.flip_average;
  DemakeupFilesReport report;
  report.photos = int64_t(photos.size());
  using Clock = std::chrono::steady_clock;
  auto ms_since = [](Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); };
  for (size_t i = 0; i < photos.size(); ++i) {
    const std::string photo = photos[i].string();
    try {
      const std::string dir = folder ? o.output + "/" + photos[i].stem().string() : o.output;
      const auto t0 = Clock::now();
      const Image image = o.aligned ? read_aligned(photo) : read_rgb(photo);
      const double read_ms = ms_since(t0);
      DemakeupResult r = o.aligned ? demakeup_aligned(d, image_tensor(image), o.uv_size)
                                   : demakeup(d, image, detector, o.uv_size, photo);
      const auto t1 = Clock::now();
      write_demakeup(r, d, dir, photo, !o.aligned);
      r.ms["write"] = ms_since(t1);
      r.ms["read"] = read_ms;
      r.ms["total"] = ms_since(t0);
      report.ms.push_back(r.ms);
    } catch (const Error& e) {
      if (!o.keep_going || !folder) throw;
      report.failed.push_back(e.what());
    }
    bareskin::report(progress, int64_t(i + 1), int64_t(photos.size()), photos[i].filename().string());
  }
  if (!report.failed.empty()) {
    for (const auto& f : report.failed) spdlog::warn("demakeup: skipped: {}", f);
    throw InvalidInput(o.input, std::to_string(report.failed.size()) + " photo(s) failed (listed above)", "");
  }
  return report;
}

std::string timing_table(const std::vector<std::map<std::string, double>>& runs) {
  const size_t first = runs.size() > 1 ? 1 : 0;
  std::string out = fmt::format("stage      median ms ({} photo(s){})\n", runs.size() - first,
                                first ? ", after a warm-up" : "");
  for (const char* stage : {"read", "detect", "align", "G", "F", "render", "unwarp", "write", "total"}) {
    std::vector<double> v;
    for (size_t i = first; i < runs.size(); ++i)
      if (auto it = runs[i].find(stage); it != runs[i].end()) v.push_back(it->second);
    if (v.empty()) continue;
    std::sort(v.begin(), v.end());
    out += fmt::format("{:<10} {:9.1f}\n", stage, v[v.size() / 2]);
  }
  return out;
}

}  // namespace bareskin::bsn
