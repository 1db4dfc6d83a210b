#include "relocalizer/core/key_frame_rule.h"

#include <cmath>
#include <cstdio>
#include <vector>

#include "relocalizer/core/number_list.h"

namespace relocalizer {

Expected<KeyFrameMotion> parseMinMotion(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return makeError("bad --min-motion '" + text + "': " + why +
                     " (expected METRES,DEGREES such as 0.05,5; 0 turns selection off)");
  };
  auto parsed = parseNumberList(text);
  if (!parsed) return bad(parsed.error());
  const std::vector<double>& values = *parsed;
  for (double value : values)
    if (value < 0) {
      char item[32];
      std::snprintf(item, sizeof item, "'%g' must be >= 0", value);
      return bad(item);
    }
  if (values.empty() || values.size() > 2) return bad("expected one or two numbers");
  return KeyFrameMotion{values[0], values.size() > 1 ? values[1] : 0.0};
}

std::string formatMinMotion(const KeyFrameMotion& motion) {
  char text[64];
  std::snprintf(text, sizeof text, "%g,%g", motion.metres, motion.degrees);
  return text;
}

double keyFrameDistance(const Pose& a, const Pose& b) {
  const KeyFrameMotion step;
  return translationError(a, b) / step.metres + rotationErrorDegrees(a, b) / step.degrees;
}

bool KeyFrameSelector::due(const Pose& pose) const {
  if (!active() || !last_) return true;
  const bool moved = motion_.metres > 0 && translationError(pose, *last_) >= motion_.metres;
  const bool turned = motion_.degrees > 0 && rotationErrorDegrees(pose, *last_) >= motion_.degrees;
  return moved || turned;
}

bool KeyFrameSelector::keep(const Pose& pose) {
  if (!due(pose)) return false;
  take(pose);
  return true;
}

}  // namespace relocalizer
