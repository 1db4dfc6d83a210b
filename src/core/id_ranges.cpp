#include "relocalizer/core/id_ranges.h"

#include <algorithm>

namespace relocalizer {

std::string joinIdRanges(const std::vector<std::pair<int, int>>& ranges) {
  std::string out;
  for (const auto& [first, last] : ranges) {
    if (!out.empty()) out += ',';
    out +=
        first == last ? std::to_string(first) : std::to_string(first) + "-" + std::to_string(last);
  }
  return out;
}

std::string formatIdRanges(std::vector<int> ids) {
  if (ids.empty()) return "none";
  std::sort(ids.begin(), ids.end());
  std::vector<std::pair<int, int>> ranges;
  for (int id : ids) {
    if (!ranges.empty() && static_cast<long long>(id) - 1 <= ranges.back().second)
      ranges.back().second = std::max(ranges.back().second, id);
    else
      ranges.emplace_back(id, id);
  }
  return joinIdRanges(ranges);
}

}  // namespace relocalizer
