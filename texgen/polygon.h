// Even-odd scanline fill of a closed 2D polygon on a pixel grid (pixel centres at +0.5): calls set(x, y) for every
// pixel of the width x height grid whose centre is inside. Used for landmark-polygon masks in image space (ingest)
// and makeup regions in UV space.
#pragma once
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <vector>

namespace bareskin {

template <class SetPixel>
void fill_polygon(const std::vector<Eigen::Vector2d>& poly, int width, int height, SetPixel set) {
  if (poly.size() < 3) return;
  double ylo = poly[0].y(), yhi = poly[0].y();
  for (const auto& p : poly) ylo = std::min(ylo, p.y()), yhi = std::max(yhi, p.y());
  const int y0 = std::max(0, int(std::floor(ylo))), y1 = std::min(height, int(std::ceil(yhi)) + 1);
  std::vector<double> xs;
  for (int y = y0; y < y1; ++y) {
    const double yc = y + 0.5;
    xs.clear();
    for (size_t i = 0; i < poly.size(); ++i) {
      const Eigen::Vector2d& a = poly[i];
      const Eigen::Vector2d& b = poly[(i + 1) % poly.size()];
      if ((a.y() <= yc) != (b.y() <= yc)) xs.push_back(a.x() + (yc - a.y()) / (b.y() - a.y()) * (b.x() - a.x()));
    }
    std::sort(xs.begin(), xs.end());
    for (size_t k = 0; k + 1 < xs.size(); k += 2) {
      const int xa = std::max(0, int(std::ceil(xs[k] - 0.5))), xb = std::min(width - 1, int(std::floor(xs[k + 1] - 0.5)));
      for (int x = xa; x <= xb; ++x) set(x, y);
    }
  }
}

}  // namespace bareskin
