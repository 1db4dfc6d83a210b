#include "place_rules.h"

#include <cstdio>

namespace relocalizer::detail {

float hintFactor(const Place& place, const PoseHint* hint, const Pose* pose) {
  const PoseHint* heard = hintFor(place, hint);
  if (!heard) return 1.0f;
  const double weight = place.relocalizer->params().solver.hint_weight;
  if (!pose) return static_cast<float>(1.0 + weight);
  const Expected<HintPrior> prior = HintPrior::make(*heard);
  return prior ? static_cast<float>(prior->factor(*pose, weight)) : 1.0f;
}

std::string ambiguityMessage(const std::string& a, const Relocalization& answer_a,
                             const std::string& b, const Relocalization& answer_b) {
  char buffer[400];
  std::snprintf(buffer, sizeof buffer,
                "ambiguous place: the frame fits %s (%d inliers) and %s (%d inliers) alike",
                a.c_str(), inliersOf(answer_a), b.c_str(), inliersOf(answer_b));
  return buffer;
}

std::string disagreementMessage(const std::string& a, const Relocalization& answer_a,
                                const std::string& b, const Relocalization& answer_b) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer, "; one map, but their poses are %.2f m and %.1f deg apart",
                translationError(answer_a.pose, answer_b.pose),
                rotationErrorDegrees(answer_a.pose, answer_b.pose));
  return ambiguityMessage(a, answer_a, b, answer_b) + buffer;
}

}  // namespace relocalizer::detail
