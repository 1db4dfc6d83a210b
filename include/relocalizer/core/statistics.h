#pragma once
// Order statistics for every table the package prints (accuracy medians,
// latency medians and 95th percentiles, ground-truth checks), so "median" and
// "p95" are the same computation everywhere.

#include <vector>

namespace relocalizer {

// Median of a copy: the mean of the two middle values for an even count; NaN when empty.
double median(std::vector<double> values);
// Linear-interpolated percentile in [0, 100] (the "linear" method of numpy and
// R type 7); NaN when empty.
double percentile(std::vector<double> values, double percent);

}  // namespace relocalizer
