#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "imufusion/eval.hpp"

namespace imufusion {

ErrorStats compute_error_stats(const std::vector<double>& values) {
  ErrorStats stats;
  stats.count = values.size();
  if (values.empty()) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    stats.rmse = stats.mean = stats.median = stats.std = stats.min = stats.max = nan;
    return stats;
  }
  const double n = static_cast<double>(values.size());
  double sum = 0.0;
  double sum_squares = 0.0;
  for (double v : values) {
    sum += v;
    sum_squares += v * v;
  }
  stats.mean = sum / n;
  stats.rmse = std::sqrt(sum_squares / n);
  // Two-pass variance: the one-pass form loses digits when the spread is small against the mean.
  double sum_deviation_squares = 0.0;
  for (double v : values) sum_deviation_squares += (v - stats.mean) * (v - stats.mean);
  stats.std = std::sqrt(sum_deviation_squares / n);

  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  stats.min = sorted.front();
  stats.max = sorted.back();
  const std::size_t mid = sorted.size() / 2;
  stats.median = sorted.size() % 2 == 1 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return stats;
}

}  // namespace imufusion
