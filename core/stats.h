// Small summary statistics for reports and benchmarks.
#pragma once
#include <algorithm>
#include <cstddef>
#include <vector>

namespace bareskin {

// The value at quantile q in [0, 1] of `values` (nearest rank, on a copy), 0 when empty.
inline double quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  const size_t k = std::min(values.size() - 1, size_t(q * double(values.size())));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

// The median of `values` (on a copy; the mean of the two middle values for an even count), 0 when empty.
inline double median(std::vector<double> values) {
  if (values.empty()) return 0;
  const size_t m = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(m), values.end());
  if (values.size() % 2) return values[m];
  return 0.5 * (*std::max_element(values.begin(), values.begin() + std::ptrdiff_t(m)) + values[m]);
}

}  // namespace bareskin
