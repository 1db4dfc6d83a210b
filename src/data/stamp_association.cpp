#include "relocalizer/data/stamp_association.h"

#include <algorithm>
#include <cmath>

namespace relocalizer {

std::vector<std::pair<size_t, size_t>> associateByStamp(const std::vector<double>& first,
                                                        const std::vector<double>& second,
                                                        double max_gap) {
  struct Candidate {
    double gap;
    size_t first, second;
  };
  // Both lists are sorted, so the candidates of each item come from a sliding
  // window of the other instead of from all pairs. The window bounds use the
  // same differences as the gaps, so they never drop a candidate.
  std::vector<Candidate> candidates;
  size_t window = 0;
  for (size_t f = 0; f < first.size(); ++f) {
    while (window < second.size() && first[f] - second[window] > max_gap) ++window;
    for (size_t s = window; s < second.size() && second[s] - first[f] <= max_gap; ++s) {
      const double gap = std::abs(first[f] - second[s]);
      if (gap <= max_gap) candidates.push_back({gap, f, s});
    }
  }
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    if (a.gap != b.gap) return a.gap < b.gap;
    if (a.first != b.first) return a.first < b.first;
    return a.second < b.second;
  });
  std::vector<bool> first_used(first.size(), false), second_used(second.size(), false);
  std::vector<std::pair<size_t, size_t>> matches;
  for (const Candidate& c : candidates) {
    if (first_used[c.first] || second_used[c.second]) continue;
    first_used[c.first] = second_used[c.second] = true;
    matches.emplace_back(c.first, c.second);
  }
  std::sort(matches.begin(), matches.end());
  return matches;
}

}  // namespace relocalizer
