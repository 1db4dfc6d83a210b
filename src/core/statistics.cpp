#include "relocalizer/core/statistics.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace relocalizer {

double median(std::vector<double> values) { return percentile(std::move(values), 50.0); }

double percentile(std::vector<double> values, double percent) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(values.begin(), values.end());
  const double position = std::clamp(percent, 0.0, 100.0) / 100.0 * (values.size() - 1);
  const size_t below = static_cast<size_t>(std::floor(position));
  const size_t above = std::min(below + 1, values.size() - 1);
  const double fraction = position - below;
  if (fraction == 0.0 || values[below] == values[above]) return values[below];
  return values[below] + fraction * (values[above] - values[below]);
}

}  // namespace relocalizer
