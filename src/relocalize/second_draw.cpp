#include "relocalizer/relocalize/second_draw.h"

#include <cstdio>
#include <string>

#include "relocalizer/core/pose.h"

namespace relocalizer {

bool needsSecondDraw(const Relocalization& answer, float confirm_below) {
  return answer.success && answer.score < confirm_below;
}

Relocalization confirmedBySecondDraw(Relocalization first, const Relocalization& second,
                                     float confirm_below) {
  first.second_draw = true;
  first.timings.total += second.timings.total;
  if (second.success && posesAgree(first.pose, second.pose)) return first;
  char weak[160];
  std::snprintf(weak, sizeof weak,
                "weak evidence not confirmed: %.1f%% of the samples are inliers (below %.1f%% a "
                "second draw of other pixels must agree), and the second draw ",
                100.0 * first.score, 100.0 * confirm_below);
  if (second.success) {
    char apart[96];
    std::snprintf(apart, sizeof apart, "answered %.2f m and %.1f deg away",
                  translationError(first.pose, second.pose),
                  rotationErrorDegrees(first.pose, second.pose));
    first.message = weak + std::string(apart);
  } else {
    first.message = weak + ("found no pose: " + second.message);
  }
  first.success = false;
  return first;
}

}  // namespace relocalizer
