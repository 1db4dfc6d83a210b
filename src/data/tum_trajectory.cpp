// TUM trajectory files.

#include "relocalizer/data/tum_trajectory.h"

#include <algorithm>
#include <cmath>

#include "dataset_text_files.h"

namespace relocalizer {

Expected<std::vector<TrajectorySample>> readTumTrajectory(const std::string& path) {
  using namespace detail;
  const fs::path file(path);
  auto lines = readLines(file);
  if (!lines) return makeError(lines.error());
  std::vector<TrajectorySample> samples;
  for (size_t i = 0; i < lines->size(); ++i) {
    if (isCommentOrBlank((*lines)[i])) continue;
    const int line_number = static_cast<int>(i) + 1;
    const std::string where = file.string() + ": line " + std::to_string(line_number);
    auto n = parseNumbers((*lines)[i], file, line_number);
    if (!n) return makeError(n.error());
    if (n->size() != 8)
      return makeError(where + ": expected 8 numbers (timestamp tx ty tz qx qy qz qw), got " +
                       std::to_string(n->size()));
    for (double value : *n)
      if (!std::isfinite(value))
        return makeError(where + ": pose contains " +
                         (std::isnan(value) ? std::string("NaN") : std::string("Inf")));
    const auto& v = *n;
    // Eigen's constructor takes w first; the file has it last.
    const Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
    if (q.norm() < 1e-6) return makeError(where + ": quaternion has zero length");
    samples.push_back({v[0], Eigen::Vector3d(v[1], v[2], v[3]), q.normalized()});
  }
  std::stable_sort(
      samples.begin(), samples.end(),
      [](const TrajectorySample& a, const TrajectorySample& b) { return a.stamp < b.stamp; });
  return samples;
}

}  // namespace relocalizer
