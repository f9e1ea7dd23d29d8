#include "training/run_log.h"

#include <fmt/format.h>
#include <torch/torch.h>

#include <cstring>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/files.h"
#include "core/png.h"
#include "core/svg_chart.h"
#ifdef BARESKIN_WITH_TENSORBOARD
#include "training/tensorboard.h"
#endif

namespace bareskin::train {
namespace fs = std::filesystem;

#ifdef BARESKIN_WITH_TENSORBOARD
struct RunLog::TensorBoard {
  EventWriter writer;
  explicit TensorBoard(const std::string& dir) : writer(dir) {}
};
#else
struct RunLog::TensorBoard {};
#endif

namespace {

std::string png_bytes(const torch::Tensor& chw) {
  auto hwc = chw.detach().to(torch::kCPU, torch::kFloat32).clamp(0, 1).permute({1, 2, 0}).contiguous();
  Image image(int(hwc.size(1)), int(hwc.size(0)), int(hwc.size(2)));
  std::memcpy(image.pixels.data(), hwc.data_ptr<float>(), image.pixels.size() * sizeof(float));
  return encode_png(image);
}

}  // namespace

RunLog::RunLog(std::string run_dir, int64_t start_step) : dir_(std::move(run_dir)) {
  for (const std::string file : {"metrics.csv", "eval.csv"}) {
    const std::string path = dir_ + "/" + file;
    std::string kept = "step,name,value\n";
    if (fs::exists(path)) {
      std::istringstream in(read_file(path));
      std::string line;
      std::getline(in, line);  // header
      while (std::getline(in, line)) {
        std::istringstream row(line);
        std::string step, name, value;
        if (!std::getline(row, step, ',') || !std::getline(row, name, ',') || !std::getline(row, value)) continue;
        if (std::stoll(step) > start_step) continue;
        history_[file][name].push_back({std::stoll(step), std::stod(value)});
        kept += line + "\n";
      }
    }
    write_file_atomic(path, kept);
  }
#ifdef BARESKIN_WITH_TENSORBOARD
  tensorboard_ = std::make_unique<TensorBoard>(dir_);  // a new event file per (re)start; TensorBoard merges them
#endif
}

RunLog::~RunLog() = default;

void RunLog::append(const std::string& file, int64_t step, const std::map<std::string, double>& values) {
  std::ofstream out(dir_ + "/" + file, std::ios::app);
  for (const auto& [name, value] : values) {
    out << step << "," << name << "," << fmt::format("{:.9g}", value) << "\n";
    history_[file][name].push_back({step, value});
#ifdef BARESKIN_WITH_TENSORBOARD
    const bool rate = name.rfind("lr/", 0) == 0;
    tensorboard_->writer.add_scalar((file == "eval.csv" ? "eval/" : rate ? "" : "loss/") + name, value, step);
#endif
  }
  if (!out) throw IoError(dir_ + "/" + file, "cannot be appended to", "check free space");
}

void RunLog::chart(const std::string& file, const std::string& title, const std::string& y_label, bool log_y,
                   const std::string& prefix) {
  Chart chart{title, "step", y_label, {}};
  chart.log_y = log_y;
  chart.y_from_zero = !log_y;
  for (const auto& [name, points] : history_[file]) {
    if (name.rfind(prefix, 0) != 0 && !(prefix.empty() && name.rfind("lr/", 0) != 0)) continue;
    if (prefix.empty() && name.rfind("lr/", 0) == 0) continue;
    ChartSeries s{name, {}, {}};
    for (const auto& [step, value] : points) {
      if (log_y && value <= 0) continue;
      s.x.push_back(double(step));
      s.y.push_back(value);
    }
    if (!s.x.empty()) chart.series.push_back(std::move(s));
  }
  if (chart.series.empty()) return;
  const std::string svg = file == "metrics.csv" ? (prefix == "lr/" ? "lr.svg" : "losses.svg") : "eval.svg";
  write_file_atomic(dir_ + "/" + svg, svg_line_chart(chart));
}

void RunLog::losses(int64_t step, const std::map<std::string, double>& losses,
                    const std::map<std::string, double>& rates) {
  std::map<std::string, double> values = losses;
  for (const auto& [group, rate] : rates) values["lr/" + group] = rate;
  append("metrics.csv", step, values);
  bool positive = true;
  for (const auto& [name, value] : losses) positive = positive && value > 0;
  chart("metrics.csv", "training losses (mean per logging interval)", "loss", positive, "");
  chart("metrics.csv", "learning rates", "learning rate", false, "lr/");
}

void RunLog::evaluation(int64_t step, const std::map<std::string, double>& metrics) {
  append("eval.csv", step, metrics);
  chart("eval.csv", "validation", "value", false, "");
}

torch::Tensor image_grid(const std::vector<std::vector<torch::Tensor>>& rows) {
  namespace F = torch::nn::functional;
  const int64_t gap = 2;
  std::vector<torch::Tensor> lines;
  int64_t width = 0;
  for (const auto& row : rows) {
    if (row.empty()) continue;
    const int64_t h = row[0].size(-2);
    std::vector<torch::Tensor> cells;
    for (const auto& image : row) {
      auto t = image.detach().to(torch::kCPU, torch::kFloat32);
      if (t.size(0) == 1) t = t.expand({3, t.size(1), t.size(2)});
      if (t.size(1) != h) {
        const int64_t w = std::max<int64_t>(1, t.size(2) * h / t.size(1));
        t = F::interpolate(t.unsqueeze(0), F::InterpolateFuncOptions().size(std::vector<int64_t>{h, w})
                                               .mode(torch::kBilinear).align_corners(false)).squeeze(0);
      }
      if (!cells.empty()) cells.push_back(torch::ones({3, h, gap}));
      cells.push_back(t.slice(0, 0, 3));
    }
    lines.push_back(torch::cat(cells, 2));
    width = std::max(width, lines.back().size(2));
  }
  BS_CHECK(!lines.empty(), "a grid needs images");
  std::vector<torch::Tensor> padded;
  for (auto& l : lines) {
    if (!padded.empty()) padded.push_back(torch::ones({3, gap, width}));
    padded.push_back(F::pad(l, F::PadFuncOptions({0, width - l.size(2), 0, 0}).value(1.0)));
  }
  return torch::cat(padded, 1).clamp(0, 1);
}

void RunLog::samples(int64_t step, const std::vector<std::vector<torch::Tensor>>& rows) {
  if (rows.empty()) return;
  make_directories(dir_ + "/samples");
  const std::string bytes = png_bytes(image_grid(rows));
  write_file_atomic(fmt::format("{}/samples/step_{:07d}.png", dir_, step), bytes);
#ifdef BARESKIN_WITH_TENSORBOARD
  auto grid = image_grid(rows);
  tensorboard_->writer.add_image("samples", bytes, int(grid.size(1)), int(grid.size(2)), 3, step);
#endif
}

}  // namespace bareskin::train
