#include "core/svg_chart.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

namespace bareskin {
namespace {

// About five round tick values covering [lo, hi].
std::vector<double> ticks(double lo, double hi) {
  const double span = std::max(hi - lo, 1e-12), raw = span / 5, mag = std::pow(10, std::floor(std::log10(raw)));
  const double step = raw / mag < 1.5 ? mag : raw / mag < 3.5 ? 2 * mag : raw / mag < 7.5 ? 5 * mag : 10 * mag;
  std::vector<double> t;
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) t.push_back(std::abs(v) < 1e-12 ? 0 : v);
  return t;
}

// Ticks of a logarithmic axis over [lo, hi] (log10 values): 1, 2, 5 per decade, or decades alone when many.
std::vector<double> log_ticks(double lo, double hi) {
  std::vector<double> t;
  const bool dense = hi - lo < 3;
  for (double d = std::floor(lo); d <= hi; ++d)
    for (double m : dense ? std::vector<double>{1, 2, 5} : std::vector<double>{1}) {
      const double v = d + std::log10(m);
      if (v >= lo - 1e-9 && v <= hi + 1e-9) t.push_back(v);
    }
  return t;
}

std::string escape(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : std::string(1, c);
  return out;
}

}  // namespace

std::string svg_line_chart(const Chart& chart) {
  constexpr double W = 640, H = 400, left = 70, right = 20, top = 40, bottom = 55;
  // On a log axis the y values are placed by their log10 (non-positive values are clamped to 1e-12).
  const auto fy = [&](double y) { return chart.log_y ? std::log10(std::max(y, 1e-12)) : y; };
  double x0 = 1e300, x1 = -1e300, y0 = chart.y_from_zero && !chart.log_y ? 0 : 1e300, y1 = -1e300;
  for (const auto& s : chart.series)
    for (size_t i = 0; i < s.x.size(); ++i) {
      x0 = std::min(x0, s.x[i]), x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, fy(s.y[i])), y1 = std::max(y1, fy(s.y[i]));
    }
  if (x0 > x1) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (x1 - x0 < 1e-12) x1 = x0 + 1;
  if (y1 - y0 < 1e-12) y1 = y0 + 1;
  if (chart.log_y) y0 = std::floor(y0), y1 = std::ceil(y1);
  else y1 += 0.05 * (y1 - y0);
  const auto px = [&](double x) { return left + (x - x0) / (x1 - x0) * (W - left - right); };
  const auto py = [&](double y) { return H - bottom - (y - y0) / (y1 - y0) * (H - top - bottom); };
  static const char* colors[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f"};
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\" font-size=\"12\">\n"
      "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      "<text x=\"{}\" y=\"22\" text-anchor=\"middle\" font-size=\"14\">{}</text>\n",
      W, H, W / 2, escape(chart.title));
  for (double t : ticks(x0, x1)) {
    svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{0:.1f}\" y2=\"{2:.1f}\" stroke=\"#ddd\"/>"
                       "<text x=\"{0:.1f}\" y=\"{3:.1f}\" text-anchor=\"middle\">{4:g}</text>\n",
                       px(t), py(y0), py(y1), H - bottom + 16, t);
  }
  for (double t : chart.log_y ? log_ticks(y0, y1) : ticks(y0, y1)) {
    svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" stroke=\"#ddd\"/>"
                       "<text x=\"{3:.1f}\" y=\"{4:.1f}\" text-anchor=\"end\">{5:g}</text>\n",
                       px(x0), py(t), px(x1), left - 6, py(t) + 4, chart.log_y ? std::pow(10, t) : t);
  }
  svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n", left, top,
                     W - left - right, H - top - bottom);
  svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", (left + W - right) / 2, H - 12,
                     escape(chart.x_label));
  svg += fmt::format("<text transform=\"translate(16 {}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
                     (top + H - bottom) / 2, escape(chart.y_label));
  // The legend goes to the top right unless the curves end high there: then to the bottom right.
  double right_high = 0, right_points = 0;
  for (const auto& s : chart.series)
    for (size_t i = 0; i < s.x.size(); ++i)
      if (px(s.x[i]) > W - right - 170) right_high += py(fy(s.y[i])) < (top + H - bottom) / 2, ++right_points;
  const double legend_top = right_points > 0 && right_high > right_points / 2
                                ? H - bottom - 12 - 16 * double(chart.series.size()) : top;
  for (size_t k = 0; k < chart.series.size(); ++k) {
    const ChartSeries& s = chart.series[k];
    const char* color = colors[k % 8];
    std::string points;
    for (size_t i = 0; i < s.x.size(); ++i) points += fmt::format("{:.1f},{:.1f} ", px(s.x[i]), py(fy(s.y[i])));
    svg += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"2\" points=\"{}\"/>\n", color, points);
    for (size_t i = 0; i < s.x.size(); ++i) {
      svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.5\" fill=\"{}\"/>", px(s.x[i]), py(fy(s.y[i])), color);
    }
    svg += fmt::format("\n<rect x=\"{0}\" y=\"{1}\" width=\"14\" height=\"3\" fill=\"{2}\"/>"
                       "<text x=\"{3}\" y=\"{4}\">{5}</text>\n",
                       W - right - 150, legend_top + 12 + 16 * double(k), color, W - right - 130, legend_top + 16 + 16 * double(k),
                       escape(s.name));
  }
  return svg + "</svg>\n";
}

}  // namespace bareskin
