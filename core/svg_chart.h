// Line charts as standalone SVG files (metrics curves for reports): no plotting library needed, readable anywhere.
#pragma once
#include <string>
#include <vector>

namespace bareskin {

struct ChartSeries {
  std::string name;
  std::vector<double> x, y;
};

struct Chart {
  std::string title, x_label, y_label;
  std::vector<ChartSeries> series;
  bool y_from_zero = true;
  bool log_y = false;  // logarithmic y axis (positive values; ticks at 1, 2, 5 per decade)
};

// The SVG text (640 x 400): axes with ticks, one polyline with markers per series, a legend.
std::string svg_line_chart(const Chart& chart);

}  // namespace bareskin
